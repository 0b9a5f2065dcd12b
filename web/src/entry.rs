//! The wasm entry point: `start(canvas_id)`, exported to JavaScript, and the [`Viewer`]
//! handle it returns.

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

use crate::app::{App, AppConfig};
use crate::backend::BackendChoice;
use kloub_core::job::dqs::SkinningMethod;

use crate::candy::Sample;
use crate::control::{Command, Controls, parse_loop_mode};
use crate::dom::{self, Key};
use crate::render::SkinningPath;

/// Starts the viewer on the `<canvas>` with id `canvas_id`.
///
/// Reads `?backend=` from the page URL (`gl` forces WebGL2, `webgpu` forces WebGPU; default:
/// WebGPU when available, else WebGL2), installs the panic overlay, and runs the app.
/// On failure the error overlay is shown, `dataset.status` is `"error"`, and the error is
/// returned to the caller as well. On success, resolves to the [`Viewer`] handle.
#[wasm_bindgen]
pub async fn start(canvas_id: String) -> Result<Viewer, JsValue> {
    // A second start (another logger already installed) keeps the first logger.
    let _ = eframe::WebLogger::init(log::LevelFilter::Info);
    dom::write_dataset(Key::Status.name(), "loading");
    let controls = Controls::default();
    let result = run(&canvas_id, controls.clone()).await;
    if let Err(error) = &result {
        dom::show_fatal(&format!("Kloub could not start: {}", dom::js_error_text(error)));
    }
    result.map(|()| Viewer { controls })
}

/// Controls a running viewer from JavaScript. Names are resolved against the model shown at
/// the call (an unknown name throws); the change applies at the next frame, the same way the
/// side panel's controls do. State is read back from `document.body.dataset`.
#[wasm_bindgen]
pub struct Viewer {
    controls: Controls,
}

#[wasm_bindgen]
impl Viewer {
    /// Runs every clock (clip, blended clips, layer).
    pub fn play(&self) {
        self.controls.send(Command::Play);
    }

    /// Stops every clock.
    pub fn pause(&self) {
        self.controls.send(Command::Pause);
    }

    /// Plays the clip named `name` as a click in the clip list does (crossfading with the
    /// panel's duration when something plays). `null` or `""` shows the rest pose.
    #[wasm_bindgen(js_name = playClip)]
    pub fn play_clip(&self, name: Option<String>) -> Result<(), JsValue> {
        let clip = self.clip(name)?;
        self.controls.send(Command::PlayClip(clip));
        Ok(())
    }

    /// Crossfades to the clip named `name` over `seconds` (0: cut), from the current pose.
    #[wasm_bindgen(js_name = crossfadeTo)]
    pub fn crossfade_to(&self, name: Option<String>, seconds: f32) -> Result<(), JsValue> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(JsValue::from_str(&format!("crossfade duration {seconds}: expected seconds >= 0")));
        }
        let clip = self.clip(name)?;
        self.controls.send(Command::CrossfadeTo { clip, seconds });
        Ok(())
    }

    /// Applies the clip named `clip` to the subtree under the joint (or node) named `root`
    /// with `weight` in `[0, 1]`; `null` or `""` as `clip` removes the layer.
    #[wasm_bindgen(js_name = setLayer)]
    pub fn set_layer(&self, clip: Option<String>, root: Option<String>, weight: f32) -> Result<(), JsValue> {
        let clip = self.clip(clip)?;
        let root = match (clip, root.as_deref()) {
            (None, _) => 0,
            (Some(_), Some(name)) => self.controls.node_index(name).map_err(|e| JsValue::from_str(&e))?,
            (Some(_), None) => return Err(JsValue::from_str("setLayer: a root joint name is required")),
        };
        if !(weight.is_finite() && (0.0..=1.0).contains(&weight)) {
            return Err(JsValue::from_str(&format!("layer weight {weight}: expected a number in [0, 1]")));
        }
        self.controls.send(Command::SetLayer { clip, root, weight });
        Ok(())
    }

    /// Moves the main clock to `seconds` (clamped to the clip).
    pub fn seek(&self, seconds: f32) -> Result<(), JsValue> {
        if !seconds.is_finite() {
            return Err(JsValue::from_str("seek: time must be a finite number"));
        }
        self.controls.send(Command::Seek(seconds));
        Ok(())
    }

    /// Playback speed of the base clips; negative plays backwards.
    #[wasm_bindgen(js_name = setSpeed)]
    pub fn set_speed(&self, speed: f32) -> Result<(), JsValue> {
        if !speed.is_finite() {
            return Err(JsValue::from_str("setSpeed: speed must be a finite number"));
        }
        self.controls.send(Command::SetSpeed(speed));
        Ok(())
    }

    /// Loop mode of the base clips: `"once"`, `"repeat"` or `"pingpong"`.
    #[wasm_bindgen(js_name = setLoop)]
    pub fn set_loop(&self, mode: &str) -> Result<(), JsValue> {
        let mode = parse_loop_mode(mode).map_err(|e| JsValue::from_str(&e))?;
        self.controls.send(Command::SetLoop(mode));
        Ok(())
    }

    /// Blends clips by weight: `names[i]` with `weights[i]` (relative; 0 leaves a clip out).
    #[wasm_bindgen(js_name = setBlend)]
    pub fn set_blend(&self, names: Vec<String>, weights: Vec<f32>) -> Result<(), JsValue> {
        if names.len() != weights.len() {
            return Err(JsValue::from_str("setBlend: names and weights differ in length"));
        }
        let mut blend = Vec::with_capacity(names.len());
        for (name, weight) in names.iter().zip(weights) {
            if !(weight.is_finite() && weight >= 0.0) {
                return Err(JsValue::from_str(&format!("setBlend: weight {weight} of {name:?} must be >= 0")));
            }
            blend.push((self.controls.clip_index(name).map_err(|e| JsValue::from_str(&e))?, weight));
        }
        self.controls.send(Command::SetBlend(blend));
        Ok(())
    }

    /// Skinning method: `"rigid"`, `"lbs"` (linear blend), `"dqs"` (dual quaternion) or `"sjb"`
    /// (spherical joint blending). Kept across models.
    #[wasm_bindgen(js_name = setSkinning)]
    pub fn set_skinning(&self, method: &str) -> Result<(), JsValue> {
        let method = SkinningMethod::from_name(method).ok_or_else(|| {
            JsValue::from_str(&format!("skinning {method:?}: expected \"rigid\", \"lbs\", \"dqs\" or \"sjb\""))
        })?;
        self.controls.send_global(Command::SetSkinning(method));
        Ok(())
    }

    /// Where vertices are deformed: `"gpu"` (vertex shader), `"compute"` (a compute pass;
    /// WebGPU only) or `"cpu"` (kloub_core's reference, uploaded every frame). Kept across
    /// models.
    #[wasm_bindgen(js_name = setSkinningPath)]
    pub fn set_skinning_path(&self, path: &str) -> Result<(), JsValue> {
        let path = SkinningPath::from_name(path).map_err(|e| JsValue::from_str(&e))?;
        if path == SkinningPath::Compute && !self.controls.supports_compute() {
            return Err(JsValue::from_str("setSkinningPath: \"compute\" needs WebGPU; this page runs on WebGL2"));
        }
        self.controls.send_global(Command::SetSkinningPath(path));
        Ok(())
    }

    /// Shows `n` characters in a grid (1 to 100), each playing 0.37 s later than the previous.
    /// Kept across models.
    #[wasm_bindgen(js_name = setCopies)]
    pub fn set_copies(&self, n: u32) -> Result<(), JsValue> {
        if !(1..=crate::app::MAX_COPIES as u32).contains(&n) {
            return Err(JsValue::from_str(&format!("setCopies: {n} copies: expected 1 to {}", crate::app::MAX_COPIES)));
        }
        self.controls.send(Command::SetCopies(n as usize));
        Ok(())
    }

    /// Colours skinned vertices by their distance from linear blend skinning's result (from
    /// dual quaternions' when LBS is the method): blue none, red 2% of the model's size.
    /// Vertex-shader path only.
    #[wasm_bindgen(js_name = setHeatmap)]
    pub fn set_heatmap(&self, on: bool) {
        self.controls.send_global(Command::SetHeatmap(on));
    }

    /// Inverse kinematics: drags the joint named `effector` (with `depth` joints above it
    /// rotating, default 2) towards the world point `x, y, z` (all three omitted: where the
    /// joint is now, to drag it from there in the viewport). Sets that joint's goal, or adds
    /// one: several effectors are solved together. `null` removes every goal.
    #[wasm_bindgen(js_name = setIkTarget)]
    pub fn set_ik_target(
        &self,
        effector: Option<String>,
        x: Option<f32>,
        y: Option<f32>,
        z: Option<f32>,
        depth: Option<u32>,
    ) -> Result<(), JsValue> {
        let Some(name) = effector else {
            self.controls.send(Command::SetIk { effector: None, depth: 0, target: None });
            return Ok(());
        };
        let target = match (x, y, z) {
            (None, None, None) => None,
            (Some(x), Some(y), Some(z)) if x.is_finite() && y.is_finite() && z.is_finite() => Some([x, y, z]),
            _ => return Err(JsValue::from_str("setIkTarget: give x, y and z as finite numbers, or none of them")),
        };
        let effector = self.controls.node_index(&name).map_err(|e| JsValue::from_str(&e))?;
        let depth = depth.unwrap_or(2) as usize;
        if !(1..32).contains(&depth) {
            return Err(JsValue::from_str(&format!("setIkTarget: depth {depth}: expected 1 to 31")));
        }
        self.controls.send(Command::SetIk { effector: Some(effector), depth, target });
        Ok(())
    }

    /// Shows a built-in sample: `"candy-wrapper"`.
    #[wasm_bindgen(js_name = loadSample)]
    pub fn load_sample(&self, name: &str) -> Result<(), JsValue> {
        let sample = Sample::from_name(name).map_err(|e| JsValue::from_str(&e))?;
        self.controls.send_global(Command::LoadSample(sample));
        Ok(())
    }

    /// Poses the candy-wrapper sample: `twist` about the bone axis and `bend`, in degrees.
    #[wasm_bindgen(js_name = setCandyPose)]
    pub fn set_candy_pose(&self, twist: f32, bend: f32) -> Result<(), JsValue> {
        if !(twist.is_finite() && bend.is_finite()) {
            return Err(JsValue::from_str("setCandyPose: angles must be finite numbers"));
        }
        self.controls.send(Command::SetCandyPose { twist, bend });
        Ok(())
    }

    /// Names of the shown model's clips.
    #[wasm_bindgen(getter, js_name = availableAnimations)]
    pub fn available_animations(&self) -> Vec<String> {
        self.controls.clip_names()
    }

    fn clip(&self, name: Option<String>) -> Result<Option<usize>, JsValue> {
        match name.as_deref() {
            None | Some("") => Ok(None),
            Some(name) => self.controls.clip_index(name).map(Some).map_err(|e| JsValue::from_str(&e)),
        }
    }
}

async fn run(canvas_id: &str, controls: Controls) -> Result<(), JsValue> {
    let window = web_sys::window().ok_or("no window")?;
    let document = window.document().ok_or("no document")?;
    let canvas: web_sys::HtmlCanvasElement = document
        .get_element_by_id(canvas_id)
        .ok_or_else(|| format!("no element with id {canvas_id:?}"))?
        .dyn_into()
        .map_err(|_| format!("#{canvas_id} is not a <canvas>"))?;
    let query = web_sys::UrlSearchParams::new_with_str(&window.location().search()?)?;
    let choice = BackendChoice::from_query(query.get("backend").as_deref());

    let mut options = eframe::WebOptions::default();
    if let egui_wgpu::WgpuSetup::CreateNew(create) = &mut options.wgpu_options.wgpu_setup {
        create.instance_descriptor.backends = choice.backends();
    }

    let runner = eframe::WebRunner::new();
    // Installed after the runner's own hook, so ours runs first and then chains to eframe's,
    // which logs the panic to the console and stops the runner.
    install_panic_hook();
    let config = AppConfig { model_url: Some("/models/default.glb".to_owned()), controls };
    runner.start(canvas, options, Box::new(move |cc| Ok(Box::new(App::new(cc, config)?)))).await
}

fn install_panic_hook() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        dom::show_fatal(&info.to_string());
        previous(info);
    }));
}
