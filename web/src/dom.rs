//! Every write the app makes to the page: the `document.body.dataset` mirror that tests and
//! embedding pages read, and the fatal-error overlay. Natively these are no-ops.

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
    /// The 3D viewport's rectangle in CSS pixels, `"x,y,width,height"` (for screenshots of the view alone).
    Viewport,
    /// The main clock's time in seconds, three decimals (`""` without a model).
    Time,
    /// `"true"` while the main clock runs, else `"false"`.
    Playing,
    /// The eased weight of the incoming clip during a crossfade, two decimals; `""` when none.
    Crossfade,
    /// The layer as `"CLIP@ROOT:WEIGHT"`; `""` without a layer.
    Layer,
    /// The skinning method: `"rigid"` | `"lbs"` | `"dqs"` | `"sjb"`.
    Skinning,
    /// Where vertices are deformed: `"gpu"` | `"cpu"`.
    SkinningPath,
    /// The candy-wrapper sample's quality under the current method, `"RADIUS,VOLUME"` (radius
    /// kept at the joint and volume ratio to rest, three decimals); `""` for other models.
    Quality,
    /// `"true"` while the deviation heatmap is on, else `"false"`.
    Heatmap,
    /// The IK goal as `"EFFECTOR:ERROR"` (five decimals); `""` without IK.
    Ik,
    /// Where the IK target is drawn, `"x,y"` in CSS pixels of the page; `""` without IK.
    IkTarget,
    /// Characters shown (the model and its copies), a decimal integer; `""` without a model.
    Copies,
}

impl Key {
    /// Every key, in a fixed order.
    pub const ALL: [Key; 19] = [
        Key::Backend,
        Key::Status,
        Key::Model,
        Key::Clips,
        Key::Clip,
        Key::Error,
        Key::Frames,
        Key::Viewport,
        Key::Time,
        Key::Playing,
        Key::Crossfade,
        Key::Layer,
        Key::Skinning,
        Key::SkinningPath,
        Key::Quality,
        Key::Heatmap,
        Key::Ik,
        Key::IkTarget,
        Key::Copies,
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
            Key::Time => "time",
            Key::Playing => "playing",
            Key::Crossfade => "crossfade",
            Key::Layer => "layer",
            Key::Skinning => "skinning",
            Key::SkinningPath => "skinningPath",
            Key::Quality => "quality",
            Key::Copies => "copies",
            Key::Heatmap => "heatmap",
            Key::Ik => "ik",
            Key::IkTarget => "ikTarget",
        }
    }
}

/// Remembers what was written so each key is written only when its value changes.
#[derive(Debug, Default)]
pub struct Dataset {
    written: [Option<String>; Key::ALL.len()],
}

impl Dataset {
    /// Writes `value` under `key` unless it is already there; returns whether it wrote.
    pub fn set(&mut self, key: Key, value: &str) -> bool {
        let slot = &mut self.written[key as usize];
        if slot.as_deref() == Some(value) {
            return false;
        }
        *slot = Some(value.to_owned());
        write_dataset(key.name(), value);
        true
    }

    /// The last value written under `key`.
    pub fn get(&self, key: Key) -> Option<&str> {
        self.written[key as usize].as_deref()
    }
}

/// Offers `text` to the user as a file named `name` (a browser download). Natively it does
/// nothing and returns an error.
///
/// # Errors
/// When the page refuses (or natively).
pub fn download(name: &str, text: &str) -> Result<(), String> {
    #[cfg(target_arch = "wasm32")]
    {
        use wasm_bindgen::JsCast;
        let fail = |e: wasm_bindgen::JsValue| format!("download {name}: {e:?}");
        let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
        let parts = js_sys::Array::of1(&wasm_bindgen::JsValue::from_str(text));
        let options = web_sys::BlobPropertyBag::new();
        options.set_type("application/json");
        let blob = web_sys::Blob::new_with_str_sequence_and_options(&parts, &options).map_err(fail)?;
        let url = web_sys::Url::create_object_url_with_blob(&blob).map_err(fail)?;
        let anchor: web_sys::HtmlAnchorElement =
            document.create_element("a").map_err(fail)?.dyn_into().map_err(|_| "not an anchor".to_owned())?;
        anchor.set_href(&url);
        anchor.set_download(name);
        anchor.click();
        web_sys::Url::revoke_object_url(&url).map_err(fail)?;
        Ok(())
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = text;
        Err(format!("saving {name} needs the browser"))
    }
}

/// Sets `document.body.dataset[name] = value` (no-op natively or without a body).
pub fn write_dataset(name: &str, value: &str) {
    #[cfg(target_arch = "wasm32")]
    if let Some(body) = web_sys::window().and_then(|w| w.document()).and_then(|d| d.body()) {
        // Failure here only means the page refused the property; there is nowhere to report it.
        let _ = body.dataset().set(name, value);
    }
    #[cfg(not(target_arch = "wasm32"))]
    let _ = (name, value);
}

/// Shows an unrecoverable error: sets `dataset.status = "error"` and `dataset.error`, and puts
/// an overlay (`#kloub-panic`) with the message and a Reload button over the page.
/// Never panics (it runs inside the panic hook). Natively it does nothing.
pub fn show_fatal(message: &str) {
    write_dataset(Key::Status.name(), "error");
    write_dataset(Key::Error.name(), message);
    #[cfg(target_arch = "wasm32")]
    // Best effort: without a document there is no overlay to show.
    let _ = overlay(message);
}

#[cfg(target_arch = "wasm32")]
fn overlay(message: &str) -> Option<()> {
    use wasm_bindgen::JsCast;
    use wasm_bindgen::closure::Closure;

    const ID: &str = "kloub-panic";
    let document = web_sys::window()?.document()?;
    let body = document.body()?;
    if let Some(old) = document.get_element_by_id(ID) {
        old.remove();
    }
    let div: web_sys::HtmlElement = document.create_element("div").ok()?.dyn_into().ok()?;
    div.set_id(ID);
    div.set_attribute("role", "alert").ok()?;
    let style = div.style();
    for (property, value) in [
        ("position", "fixed"),
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
    body.append_child(&div).ok()?;
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
