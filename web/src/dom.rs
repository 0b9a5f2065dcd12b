//! Every write a viewer makes to the page: its state mirror (the `data-*` attributes of its
//! `<kloub-viewer>` element, which tests and embedding pages read), its events, and the
//! fatal-error overlay. Each viewer writes only through its own [`Host`]; natively these are
//! no-ops.

/// The page keys the app mirrors into `document.body.dataset` (see the page contract).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Key {
    /// `"webgpu"` | `"webgl2"`.
    Backend,
    /// `"loading"` | `"ready"` | `"error"`.
    Status,
    /// Current model name.
    Model,
    /// JSON array of clip names.
    Clips,
    /// Active clip name (`""` for the rest pose).
    Clip,
    /// Last error message (`""` when none).
    Error,
    /// Painted frames, a decimal integer.
    Frames,
    /// The 3D viewport's rectangle in CSS pixels of the canvas, `"x,y,width,height"` (for
    /// screenshots of the view alone).
    Viewport,
    /// The box the camera frames (the shown model over its clips, with its copies), world
    /// units, `"minx,miny,minz,maxx,maxy,maxz"`; `""` without a model.
    Bounds,
    /// The main clock's time in seconds, three decimals (`""` without a model).
    Time,
    /// `"true"` while the main clock runs, else `"false"`.
    Playing,
    /// The eased weight of the incoming clip during a crossfade, two decimals; `""` when none.
    Crossfade,
    /// The layer as `"CLIP@ROOT:WEIGHT"`; `""` without a layer.
    Layer,
    /// The skinning method: `"rigid"` | `"lbs"` | `"dqs"` | `"sjb"` | `"sjbbe"`.
    Skinning,
    /// Where vertices are deformed: `"gpu"` | `"compute"` | `"cpu"`.
    SkinningPath,
    /// `"true"` once a path was chosen (`setSkinningPath`, the panel), `"false"` while the
    /// adapter's default is used (what a link keeps: only a chosen path).
    SkinningPathChosen,
    /// The candy-wrapper sample's quality under the current method, `"RADIUS,VOLUME"` (radius
    /// kept at the joint and volume ratio to rest, three decimals); `""` for other models.
    Quality,
    /// `"true"` while the deviation heatmap is on, else `"false"`.
    Heatmap,
    /// The IK goal as `"EFFECTOR:ERROR"` (five decimals); `""` without IK.
    Ik,
    /// Where each IK target is drawn, `"x,y;x,y"` in CSS pixels of the canvas; `""` without IK.
    IkTarget,
    /// Where each IK goal's pole is drawn, as [`Key::IkTarget`], one entry per goal (`""` for a
    /// goal without a pole).
    IkPole,
    /// Characters shown (the model and its copies), a decimal integer; `""` without a model.
    Copies,
    /// The main clock's speed (three decimals; `""` without a model).
    Speed,
    /// The main clip's duration in seconds, three decimals (`"0.000"` for the rest pose).
    Duration,
    /// The main clock's loop mode: `"once"` | `"repeat"` | `"pingpong"`.
    Loop,
    /// The camera: `"yaw,pitch,distance,x,y,z"` (radians, then the target point; five decimals).
    Camera,
    /// `"true"` while the ground grid is drawn, else `"false"`.
    Grid,
    /// The overlays that are on, comma-separated: `skeleton`, `bounds`, `wireframe`, `normals`.
    Overlays,
    /// The selected joint's name (`""` when none).
    Joint,
    /// While a model downloads: `"RECEIVED/TOTAL"` bytes (TOTAL empty when unknown); else `""`.
    Progress,
    /// The lighting preset: `"studio"` | `"outdoor"` | `"flat"` | `"rim"`.
    Lighting,
    /// The background: `"dark"` | `"grey"` | `"light"` | `"transparent"`.
    Background,
    /// The exposure, a number (1: as lit).
    Exposure,
    /// The tone mapping: `"neutral"` | `"aces"` | `"none"`.
    ToneMapping,
    /// The environment: `""` (the lighting preset's), `"neutral"` | `"studio"` | `"outdoor"`, or
    /// `"image"` (an .hdr file).
    Environment,
    /// The ground shadow: `intensity,softness` (0 to 1 each; intensity 0: none).
    Shadow,
    /// The ragdoll: `"simulating"` | `"resting"` | `"blending"` (back to the animation); `""` off.
    Ragdoll,
    /// The URL the shown model was fetched from (`""` for dropped files and built-in samples).
    Src,
    /// The base blend while several clips are weighted: a JSON array of `[clip, weight]` (`""`
    /// when the main clip plays alone).
    Blend,
    /// How clip changes crossfade: `"DURATION,EASING,OUTGOING"` (e.g. `"0.250,smoothstep,freeze"`).
    Transition,
    /// The IK goals as JSON: `[{effector, depth, target: [x, y, z], solver, iterations, softness,
    /// patternMove, pole: [x, y, z] | null}]` (`""` without IK).
    IkGoals,
    /// Morph weights held by the page or the panel: a JSON array of `[node, target, weight]`
    /// (`""` when the clip drives them all).
    Morphs,
    /// The joint rotations held by `setJointRotation`: `{"JOINT": [x, y, z, w]}`; `""` without.
    Pose,
    /// `"animate"`, `"pose"` (pose mode: `setPoseMode`) or `"sculpt"` (an example pose being
    /// sculpted: `addExamplePose`).
    Mode,
    /// The ragdoll's obstacles as `setObstacles` takes them (JSON); `""` without.
    Obstacles,
    /// The models of a drop (or zip archive) holding several, a JSON array of file names, which
    /// the panel lists to switch between; `""` for one model.
    Models,
    /// The side panel: `"side"` (beside the view), `"open"` / `"closed"` (the sheet of a narrow
    /// element, over the view), `""` without panels.
    Panel,
}

impl Key {
    /// Every key, in a fixed order.
    pub const ALL: [Key; 47] = [
        Key::Backend,
        Key::Status,
        Key::Model,
        Key::Clips,
        Key::Clip,
        Key::Error,
        Key::Frames,
        Key::Viewport,
        Key::Bounds,
        Key::Time,
        Key::Playing,
        Key::Crossfade,
        Key::Layer,
        Key::Skinning,
        Key::SkinningPath,
        Key::SkinningPathChosen,
        Key::Quality,
        Key::Heatmap,
        Key::Ik,
        Key::IkTarget,
        Key::IkPole,
        Key::Copies,
        Key::Speed,
        Key::Duration,
        Key::Loop,
        Key::Camera,
        Key::Grid,
        Key::Overlays,
        Key::Joint,
        Key::Progress,
        Key::Lighting,
        Key::Background,
        Key::Exposure,
        Key::ToneMapping,
        Key::Environment,
        Key::Shadow,
        Key::Ragdoll,
        Key::Src,
        Key::Blend,
        Key::Transition,
        Key::IkGoals,
        Key::Morphs,
        Key::Pose,
        Key::Mode,
        Key::Obstacles,
        Key::Models,
        Key::Panel,
    ];

    /// The dataset property name (`dataset.<name>` in JS).
    pub fn name(self) -> &'static str {
        match self {
            Key::Backend => "backend",
            Key::Status => "status",
            Key::Model => "model",
            Key::Clips => "clips",
            Key::Clip => "clip",
            Key::Error => "error",
            Key::Frames => "frames",
            Key::Viewport => "viewport",
            Key::Bounds => "bounds",
            Key::Panel => "panel",
            Key::Time => "time",
            Key::Playing => "playing",
            Key::Crossfade => "crossfade",
            Key::Layer => "layer",
            Key::Skinning => "skinning",
            Key::SkinningPath => "skinningPath",
            Key::SkinningPathChosen => "skinningPathChosen",
            Key::Quality => "quality",
            Key::Copies => "copies",
            Key::Heatmap => "heatmap",
            Key::Ik => "ik",
            Key::IkTarget => "ikTarget",
            Key::IkPole => "ikPole",
            Key::Speed => "speed",
            Key::Duration => "duration",
            Key::Loop => "loop",
            Key::Camera => "camera",
            Key::Grid => "grid",
            Key::Overlays => "overlays",
            Key::Joint => "joint",
            Key::Progress => "progress",
            Key::Lighting => "lighting",
            Key::Background => "background",
            Key::Exposure => "exposure",
            Key::ToneMapping => "toneMapping",
            Key::Environment => "environment",
            Key::Shadow => "shadow",
            Key::Ragdoll => "ragdoll",
            Key::Src => "src",
            Key::Blend => "blend",
            Key::Transition => "transition",
            Key::IkGoals => "ikGoals",
            Key::Morphs => "morphs",
            Key::Pose => "pose",
            Key::Mode => "mode",
            Key::Obstacles => "obstacles",
            Key::Models => "models",
        }
    }
}

/// Where one viewer mirrors its state, reports its events and shows a fatal error: its
/// `<kloub-viewer>` element, the element's shadow root and the element's event callback.
/// The default host (natively, and before an element exists) writes nowhere.
#[derive(Clone, Default)]
pub struct Host {
    #[cfg(target_arch = "wasm32")]
    element: Option<web_sys::HtmlElement>,
    #[cfg(target_arch = "wasm32")]
    overlay: Option<web_sys::Node>,
    #[cfg(target_arch = "wasm32")]
    emit: Option<js_sys::Function>,
}

impl std::fmt::Debug for Host {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Host")
    }
}

#[cfg(target_arch = "wasm32")]
impl Host {
    /// A host writing `element.dataset`, putting the error overlay into `overlay` (the
    /// element's shadow root) and calling `emit(type, detail)` for each event.
    pub fn new(element: web_sys::HtmlElement, overlay: web_sys::Node, emit: Option<js_sys::Function>) -> Self {
        Self { element: Some(element), overlay: Some(overlay), emit }
    }

    fn same(&self, other: &Host) -> bool {
        self.element.is_some() && self.element == other.element
    }
}

impl Host {
    /// Sets `element.dataset[name] = value`.
    pub fn write(&self, name: &str, value: &str) {
        #[cfg(target_arch = "wasm32")]
        if let Some(element) = &self.element {
            // Failure here only means the page refused the property; there is nowhere to report it.
            let _ = element.dataset().set(name, value);
        }
        #[cfg(not(target_arch = "wasm32"))]
        let _ = (name, value);
    }

    /// Reports an event (`load`, `error`, `play`, `pause`, `timeupdate`, `loop`, `finished`)
    /// with a text detail; the element dispatches it as a DOM event.
    pub fn emit(&self, event: &str, detail: &str) {
        #[cfg(target_arch = "wasm32")]
        if let Some(emit) = &self.emit {
            let _ = emit.call2(
                &wasm_bindgen::JsValue::NULL,
                &wasm_bindgen::JsValue::from_str(event),
                &wasm_bindgen::JsValue::from_str(detail),
            );
        }
        #[cfg(not(target_arch = "wasm32"))]
        let _ = (event, detail);
    }

    /// Shows an unrecoverable error: `data-status="error"`, `data-error`, an `error` event and
    /// an overlay (`.kloub-panic`) with the message and a Reload button over the viewer.
    /// Never panics (it runs inside the panic hook).
    pub fn show_fatal(&self, message: &str) {
        self.write(Key::Status.name(), "error");
        self.write(Key::Error.name(), message);
        self.emit("error", message);
        #[cfg(target_arch = "wasm32")]
        if let Some(parent) = &self.overlay {
            // Best effort: without a document there is no overlay to show.
            let _ = overlay(parent, message);
        }
    }
}

#[cfg(target_arch = "wasm32")]
thread_local! {
    /// Every mounted viewer's host: a panic stops the whole wasm instance, so every viewer
    /// on the page shows the error.
    static HOSTS: std::cell::RefCell<Vec<Host>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Registers a mounted viewer's host for [`show_fatal_everywhere`].
#[cfg(target_arch = "wasm32")]
pub fn register(host: &Host) {
    HOSTS.with(|h| {
        if let Ok(mut hosts) = h.try_borrow_mut() {
            hosts.push(host.clone());
        }
    });
}

/// Forgets an unmounted viewer's host.
#[cfg(target_arch = "wasm32")]
pub fn unregister(host: &Host) {
    HOSTS.with(|h| {
        if let Ok(mut hosts) = h.try_borrow_mut() {
            hosts.retain(|other| !other.same(host));
        }
    });
}

/// Shows `message` as a fatal error in every mounted viewer (from the panic hook).
#[cfg(target_arch = "wasm32")]
pub fn show_fatal_everywhere(message: &str) {
    HOSTS.with(|h| {
        if let Ok(hosts) = h.try_borrow() {
            hosts.iter().for_each(|host| host.show_fatal(message));
        }
    });
}

/// Remembers what was written so each key is written only when its value changes.
#[derive(Debug)]
pub struct Dataset {
    written: [Option<String>; Key::ALL.len()],
    host: Host,
}

impl Default for Dataset {
    fn default() -> Self {
        Self::new(Host::default())
    }
}

impl Dataset {
    /// A mirror writing through `host`.
    pub fn new(host: Host) -> Self {
        Self { written: std::array::from_fn(|_| None), host }
    }

    /// Where this mirror writes and reports events.
    pub fn host(&self) -> &Host {
        &self.host
    }

    /// Writes `value` under `key` unless it is already there; returns whether it wrote.
    pub fn set(&mut self, key: Key, value: &str) -> bool {
        let slot = &mut self.written[key as usize];
        if slot.as_deref() == Some(value) {
            return false;
        }
        *slot = Some(value.to_owned());
        self.host.write(key.name(), value);
        true
    }

    /// Forgets what was written under `key`, so the next [`Dataset::set`] writes it (the
    /// page changed it meanwhile, e.g. `data-status="lost"`).
    pub fn forget(&mut self, key: Key) {
        self.written[key as usize] = None;
    }

    /// The last value written under `key`.
    pub fn get(&self, key: Key) -> Option<&str> {
        self.written[key as usize].as_deref()
    }
}

/// Offers `bytes` to the user as a file named `name` of type `mime` (a browser download).
/// Natively it does nothing and returns an error.
///
/// # Errors
/// When the page refuses (or natively).
pub fn download(name: &str, bytes: &[u8], mime: &str) -> Result<(), String> {
    #[cfg(target_arch = "wasm32")]
    {
        let fail = |e: wasm_bindgen::JsValue| format!("download {name}: {e:?}");
        let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
        let parts = js_sys::Array::of1(&js_sys::Uint8Array::from(bytes));
        let options = web_sys::BlobPropertyBag::new();
        options.set_type(mime);
        let blob = web_sys::Blob::new_with_u8_array_sequence_and_options(&parts, &options).map_err(fail)?;
        offer_blob(&document, name, &blob)
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = (bytes, mime);
        Err(format!("saving {name} needs the browser"))
    }
}

/// Offers `width × height` RGBA8 `pixels` (straight alpha) as the PNG file `name`, encoded by the
/// browser (a canvas's `toBlob`): the widget builds carry no PNG encoder.
///
/// # Errors
/// The browser refused a step (no document, no 2D context, a size it cannot hold).
#[cfg(target_arch = "wasm32")]
pub fn download_rgba(name: &str, pixels: &[u8], width: u32, height: u32) -> Result<(), String> {
    use wasm_bindgen::JsCast;
    let fail = |e: wasm_bindgen::JsValue| format!("download {name}: {}", js_error_text(&e));
    let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
    let canvas: web_sys::HtmlCanvasElement =
        document.create_element("canvas").map_err(fail)?.dyn_into().map_err(|_| "not a canvas".to_owned())?;
    canvas.set_width(width);
    canvas.set_height(height);
    let context: web_sys::CanvasRenderingContext2d = canvas
        .get_context("2d")
        .map_err(fail)?
        .and_then(|c| c.dyn_into().ok())
        .ok_or_else(|| format!("download {name}: no 2D canvas"))?;
    let image = web_sys::ImageData::new_with_u8_clamped_array_and_sh(wasm_bindgen::Clamped(pixels), width, height)
        .map_err(fail)?;
    context.put_image_data(&image, 0.0, 0.0).map_err(fail)?;
    // Encoded off the main thread into a Blob, offered by an object URL (no base64 copy).
    let name = name.to_owned();
    let done = wasm_bindgen::closure::Closure::once_into_js(move |blob: Option<web_sys::Blob>| {
        if let Err(message) = blob.ok_or_else(|| "no PNG".to_owned()).and_then(|b| offer_blob(&document, &name, &b)) {
            log::error!("kloub: the browser could not encode the screenshot {name}: {message}");
        }
    });
    canvas.to_blob_with_type(done.unchecked_ref(), "image/png").map_err(fail)?;
    Ok(())
}

/// Offers `blob` as the file `name`: an anchor with `download`, clicked, over an object URL that
/// is let go at once (the browser keeps what it started downloading).
#[cfg(target_arch = "wasm32")]
fn offer_blob(document: &web_sys::Document, name: &str, blob: &web_sys::Blob) -> Result<(), String> {
    use wasm_bindgen::JsCast;
    let fail = |e: wasm_bindgen::JsValue| format!("download {name}: {}", js_error_text(&e));
    let url = web_sys::Url::create_object_url_with_blob(blob).map_err(fail)?;
    let anchor: web_sys::HtmlAnchorElement =
        document.create_element("a").map_err(fail)?.dyn_into().map_err(|_| "not an anchor".to_owned())?;
    anchor.set_href(&url);
    anchor.set_download(name);
    anchor.click();
    web_sys::Url::revoke_object_url(&url).map_err(fail)
}

#[cfg(target_arch = "wasm32")]
fn overlay(parent: &web_sys::Node, message: &str) -> Option<()> {
    use wasm_bindgen::JsCast;
    use wasm_bindgen::closure::Closure;

    const CLASS: &str = "kloub-panic";
    let document = web_sys::window()?.document()?;
    let mut child = parent.first_child();
    while let Some(node) = child {
        child = node.next_sibling();
        if node.dyn_ref::<web_sys::Element>().is_some_and(|e| e.class_name() == CLASS) {
            let _ = parent.remove_child(&node);
        }
    }
    let div: web_sys::HtmlElement = document.create_element("div").ok()?.dyn_into().ok()?;
    div.set_class_name(CLASS);
    div.set_attribute("role", "alert").ok()?;
    let style = div.style();
    for (property, value) in [
        ("position", "absolute"),
        ("inset", "0"),
        ("z-index", "2147483647"),
        ("display", "flex"),
        ("flex-direction", "column"),
        ("align-items", "center"),
        ("justify-content", "center"),
        ("gap", "1em"),
        ("padding", "2em"),
        ("background", "rgba(20, 20, 24, 0.92)"),
        ("color", "#f0f0f0"),
        ("font", "16px system-ui, sans-serif"),
        ("text-align", "center"),
    ] {
        style.set_property(property, value).ok()?;
    }
    let title = document.create_element("strong").ok()?;
    title.set_text_content(Some("Kloub stopped because of an error."));
    let text = document.create_element("pre").ok()?;
    text.set_text_content(Some(message));
    let pre: &web_sys::HtmlElement = text.dyn_ref()?;
    pre.style().set_property("white-space", "pre-wrap").ok()?;
    pre.style().set_property("max-width", "60em").ok()?;
    let button: web_sys::HtmlElement = document.create_element("button").ok()?.dyn_into().ok()?;
    button.set_text_content(Some("Reload"));
    let reload = Closure::<dyn FnMut()>::new(|| {
        if let Some(window) = web_sys::window() {
            let _ = window.location().reload();
        }
    });
    button.set_onclick(Some(reload.as_ref().unchecked_ref()));
    // The page is being torn down by the error; the handler lives as long as the page.
    reload.forget();
    div.append_child(&title).ok()?;
    div.append_child(&text).ok()?;
    div.append_child(&button).ok()?;
    parent.append_child(&div).ok()?;
    Some(())
}

/// A readable message from a thrown JS value (an `Error`'s message, or its string form).
#[cfg(target_arch = "wasm32")]
pub fn js_error_text(value: &wasm_bindgen::JsValue) -> String {
    use wasm_bindgen::JsCast;
    if let Some(error) = value.dyn_ref::<js_sys::Error>() {
        return String::from(error.message());
    }
    value.as_string().unwrap_or_else(|| format!("{value:?}"))
}

/// Calls the element's loader `loader` (a function the page handed over, if any) with `arg` and
/// gives the promise it returns, or why there is none: the loader threw, gave something else
/// (`"the element's {what} gave no promise"`) or was never handed over (`missing`).
#[cfg(target_arch = "wasm32")]
pub fn loader_promise(
    loader: &std::cell::RefCell<Option<js_sys::Function>>,
    arg: &wasm_bindgen::JsValue,
    what: &str,
    missing: &str,
) -> Result<js_sys::Promise, String> {
    use wasm_bindgen::JsCast;
    // The borrow ends with the call: nothing below holds it.
    let called = loader.borrow().as_ref().map(|f| f.call1(&wasm_bindgen::JsValue::NULL, arg));
    match called {
        Some(Ok(p)) => p.dyn_into::<js_sys::Promise>().map_err(|_| format!("the element's {what} gave no promise")),
        Some(Err(e)) => Err(js_error_text(&e)),
        None => Err(missing.to_owned()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_only_changes() {
        let mut d = Dataset::default();
        assert!(d.set(Key::Status, "loading"));
        assert!(!d.set(Key::Status, "loading"));
        assert!(d.set(Key::Status, "ready"));
        assert!(d.set(Key::Error, ""));
        assert!(!d.set(Key::Error, ""));
        assert_eq!(d.get(Key::Status), Some("ready"));
        assert_eq!(d.get(Key::Model), None);
    }

    #[test]
    fn key_names_are_distinct() {
        let names: std::collections::HashSet<_> = Key::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names.len(), Key::ALL.len());
        for (i, k) in Key::ALL.iter().enumerate() {
            assert_eq!(*k as usize, i);
        }
    }
}
