//! Downloads the element started before the module was ready (`kloub-viewer.js` starts the
//! model's download when a viewer mounts, while the wasm still downloads and compiles): the
//! viewer's fetch takes the response ([`take_download`]) and, for a GLB, the images the browser
//! decoded meanwhile ([`take_images`]) instead of starting over. The element hands its two
//! functions over once per module instance ([`set_hooks`]).

use std::cell::RefCell;

use wasm_bindgen::{JsCast, JsValue};

thread_local! {
    static HOOKS: RefCell<Option<(js_sys::Function, js_sys::Function)>> = const { RefCell::new(None) };
}

/// `take(url)` → `{response, abort}` or `undefined`; `images(url)` → `{images, decoded}` (a
/// promise of an array, a bitmap or `null` per image of the GLB, or of `null`; and what it
/// resolved to, `undefined` while it has not) or `undefined`. Each hands a URL's prefetch out once.
pub fn set_hooks(take: Option<js_sys::Function>, images: Option<js_sys::Function>) {
    HOOKS.with(|h| *h.borrow_mut() = take.zip(images));
}

fn call(url: &str, which: impl Fn(&(js_sys::Function, js_sys::Function)) -> &js_sys::Function) -> Option<JsValue> {
    let hooks = HOOKS.with(|h| h.borrow().clone())?;
    let value = which(&hooks).call1(&JsValue::NULL, &JsValue::from_str(url)).ok()?;
    (!value.is_undefined() && !value.is_null()).then_some(value)
}

/// A download of `url` the element started: the promise of its `Response`, and the function
/// that aborts it.
pub fn take_download(url: &str) -> Option<(js_sys::Promise, js_sys::Function)> {
    let value = call(url, |h| &h.0)?;
    let response = js_sys::Reflect::get(&value, &"response".into()).ok()?.dyn_into().ok()?;
    let abort = js_sys::Reflect::get(&value, &"abort".into()).ok()?.dyn_into().ok()?;
    Some((response, abort))
}

/// The images of a GLB the browser decoded while the module loaded (per image a bitmap, or
/// `None` where the viewer decodes itself).
pub enum EarlyImages {
    /// Decoded already: taken in the frame that asks.
    Decoded(Vec<Option<web_sys::ImageBitmap>>),
    /// Still decoding: the promise of the array (or of `null`).
    Decoding(js_sys::Promise),
}

/// The array of bitmaps (`null` or anything else: none) as [`EarlyImages::Decoded`] holds it.
pub fn bitmaps(value: JsValue) -> Vec<Option<web_sys::ImageBitmap>> {
    value.dyn_into::<js_sys::Array>().map(|a| a.iter().map(|b| b.dyn_into().ok()).collect()).unwrap_or_default()
}

/// The images of a GLB at `url` the browser decoded while the module loaded.
pub fn take_images(url: &str) -> Option<EarlyImages> {
    let value = call(url, |h| &h.1)?;
    let decoded = js_sys::Reflect::get(&value, &"decoded".into()).ok()?;
    if !decoded.is_undefined() {
        return Some(EarlyImages::Decoded(bitmaps(decoded)));
    }
    Some(EarlyImages::Decoding(js_sys::Reflect::get(&value, &"images".into()).ok()?.dyn_into().ok()?))
}
