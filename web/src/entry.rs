//! The wasm entry point: `start(canvas_id)`, exported to JavaScript.

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

use crate::app::{App, AppConfig};
use crate::backend::BackendChoice;
use crate::dom::{self, Key};

/// Starts the viewer on the `<canvas>` with id `canvas_id`.
///
/// Reads `?backend=` from the page URL (`gl` forces WebGL2, `webgpu` forces WebGPU; default:
/// WebGPU when available, else WebGL2), installs the panic overlay, and runs the app.
/// On failure the error overlay is shown, `dataset.status` is `"error"`, and the error is
/// returned to the caller as well.
#[wasm_bindgen]
pub async fn start(canvas_id: String) -> Result<(), JsValue> {
    // A second start (another logger already installed) keeps the first logger.
    let _ = eframe::WebLogger::init(log::LevelFilter::Info);
    dom::write_dataset(Key::Status.name(), "loading");
    let result = run(&canvas_id).await;
    if let Err(error) = &result {
        dom::show_fatal(&format!("Kloub could not start: {}", dom::js_error_text(error)));
    }
    result
}

async fn run(canvas_id: &str) -> Result<(), JsValue> {
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
    let config = AppConfig { model_url: Some("/models/default.glb".to_owned()) };
    runner
        .start(canvas, options, Box::new(move |cc| Ok(Box::new(App::new(cc, config)?))))
        .await
}

fn install_panic_hook() {
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        dom::show_fatal(&info.to_string());
        previous(info);
    }));
}
