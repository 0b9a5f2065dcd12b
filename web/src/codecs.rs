//! The decoders few files need (Draco streams, zip archives: [`kloub_core::codecs`]). The full
//! app and native builds have them in the module ([`kloub_core::codecs::Builtin`]); the light
//! widget builds leave them out of their first download and, when a file needs them
//! ([`kloub_core::codecs::needed`]), ask the element for the codecs module (`web/codecs`,
//! fetched once per page: [`set_loader`]) before importing it. [`ready_for`] says whether a
//! delivery's files can be imported now; [`with`] hands the importer the decoders.

use kloub_core::codecs::{Codecs, Needs};

use crate::control::Wake;
use crate::load::SourceFile;

/// What `files` need, all together.
pub fn needs(files: &[SourceFile]) -> Needs {
    files.iter().fold(Needs::default(), |all, f| {
        let one = kloub_core::codecs::needed(&f.name, &f.bytes);
        Needs { zip: all.zip || one.zip, draco: all.draco || one.draco }
    })
}

/// Calls `f` with the decoders of this build: in-process, or the codecs module once loaded.
pub fn with<R>(f: impl FnOnce(&dyn Codecs) -> R) -> R {
    #[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
    return bridge::with(f);
    #[cfg(not(all(target_arch = "wasm32", not(feature = "codecs"))))]
    return f(kloub_core::codecs::builtin());
}

/// Whether `files` can be imported now: they need no decoder, or the decoders are here. Else
/// the codecs module starts loading (once per page) and `wake` is called when it is in (or has
/// failed: the next call gives the error, and a later one tries again).
///
/// # Errors
/// The codecs module could not be loaded (the message says what the files needed).
pub fn ready_for(files: &[SourceFile], wake: Option<Wake>) -> Result<bool, String> {
    #[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
    {
        let needs = needs(files);
        if !needs.any() {
            return Ok(true);
        }
        bridge::ready(needs, wake)
    }
    #[cfg(not(all(target_arch = "wasm32", not(feature = "codecs"))))]
    {
        let _ = (files, wake);
        Ok(true)
    }
}

/// Hands over the element's `codecs()`: a function giving a promise of the codecs module
/// (`kloub_codecs.js`, initialised). Without one the widget cannot open Draco files or zips.
#[cfg(target_arch = "wasm32")]
pub fn set_loader(loader: Option<js_sys::Function>) {
    #[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
    bridge::LOADER.with(|l| *l.borrow_mut() = loader);
    #[cfg(not(all(target_arch = "wasm32", not(feature = "codecs"))))]
    let _ = loader;
}

/// Whether the codecs module is on its way.
pub fn loading() -> bool {
    #[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
    return bridge::STATE.with(|s| matches!(&*s.borrow(), bridge::State::Loading(_)));
    #[cfg(not(all(target_arch = "wasm32", not(feature = "codecs"))))]
    false
}

/// How many times the codecs module was asked for on this thread: for the tests.
pub fn loads() -> u32 {
    #[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
    return bridge::LOADS.with(std::cell::Cell::get);
    #[cfg(not(all(target_arch = "wasm32", not(feature = "codecs"))))]
    0
}

#[cfg(all(target_arch = "wasm32", not(feature = "codecs")))]
mod bridge {
    use std::cell::{Cell, RefCell};

    use kloub_core::archive::{Archive, ArchiveLimits};
    use kloub_core::codecs::{Codecs, DracoMesh, Needs, Unavailable, archive_from_bytes};
    use wasm_bindgen::{JsCast, JsValue};

    use crate::control::Wake;

    /// Where the codecs module is.
    pub(super) enum State {
        Idle,
        Loading(Vec<Wake>),
        Ready(JsValue),
        Failed(String),
    }

    thread_local! {
        /// Whether the next load must be a new instance (the last one trapped, or its load failed).
        static FRESH: Cell<bool> = const { Cell::new(false) };
        pub(super) static LOADER: RefCell<Option<js_sys::Function>> = const { RefCell::new(None) };
        pub(super) static LOADS: Cell<u32> = const { Cell::new(0) };
        pub(super) static STATE: RefCell<State> = const { RefCell::new(State::Idle) };
    }

    pub(super) fn ready(needs: Needs, wake: Option<Wake>) -> Result<bool, String> {
        let what = match (needs.draco, needs.zip) {
            (true, true) => "Draco and zip decoders",
            (true, false) => "Draco decoder",
            _ => "zip reader",
        };
        let start = STATE.with(|s| {
            let mut s = s.borrow_mut();
            match &mut *s {
                State::Ready(_) => Ok(None),
                State::Loading(waiting) => {
                    waiting.extend(wake);
                    Ok(Some(false))
                }
                State::Failed(message) => {
                    let message = format!("the {what} could not be loaded: {message}");
                    // The next file tries again (the network may be back).
                    *s = State::Idle;
                    Err(message)
                }
                State::Idle => {
                    *s = State::Loading(wake.into_iter().collect());
                    Ok(Some(true))
                }
            }
        })?;
        match start {
            None => Ok(true),
            Some(false) => Ok(false),
            Some(true) => {
                load();
                Ok(false)
            }
        }
    }

    fn settle(state: State) {
        if matches!(state, State::Failed(_)) {
            FRESH.with(|f| f.set(true));
        }
        let waiting = STATE.with(|s| match std::mem::replace(&mut *s.borrow_mut(), state) {
            State::Loading(waiting) => waiting,
            _ => Vec::new(),
        });
        for wake in waiting {
            wake.wake();
        }
    }

    fn load() {
        LOADS.with(|n| n.set(n.get() + 1));
        let fresh = JsValue::from_bool(FRESH.with(|f| f.replace(false)));
        let promise = LOADER
            .with(|l| crate::dom::loader_promise(l, &fresh, "codecs()", "this page's element does not provide them"));
        let promise = match promise {
            Ok(p) => p,
            Err(message) => return settle(State::Failed(message)),
        };
        wasm_bindgen_futures::spawn_local(async move {
            match wasm_bindgen_futures::JsFuture::from(promise).await {
                Ok(module) => settle(State::Ready(module)),
                Err(e) => settle(State::Failed(crate::dom::js_error_text(&e))),
            }
        });
    }

    /// The codecs module's functions, called with bytes, giving bytes.
    struct Bridge<'a>(&'a JsValue);

    impl Bridge<'_> {
        fn call(&self, name: &str, args: &js_sys::Array) -> Result<Vec<u8>, String> {
            let f: js_sys::Function = js_sys::Reflect::get(self.0, &name.into())
                .ok()
                .and_then(|f| f.dyn_into().ok())
                .ok_or_else(|| format!("the codecs module has no {name}()"))?;
            let out = f.apply(&JsValue::NULL, args).map_err(|e| {
                // A trap leaves the module's memory as it was mid-call: the next file loads a new instance.
                if e.is_instance_of::<js_sys::WebAssembly::RuntimeError>() {
                    FRESH.with(|f| f.set(true));
                    STATE.with(|s| *s.borrow_mut() = State::Idle);
                }
                crate::dom::js_error_text(&e)
            })?;
            let out: js_sys::Uint8Array = out.dyn_into().map_err(|_| format!("{name}() gave no bytes"))?;
            Ok(out.to_vec())
        }
    }

    impl Codecs for Bridge<'_> {
        fn draco(&self, stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<DracoMesh, String> {
            let args = js_sys::Array::of3(
                &js_sys::Uint8Array::from(stream),
                &js_sys::Uint32Array::from(wanted),
                &JsValue::from_f64(max_bytes as f64),
            );
            DracoMesh::from_bytes(&self.call("draco", &args)?)
        }

        fn unzip(&self, bytes: &[u8], limits: &ArchiveLimits) -> Result<Archive, String> {
            let args = js_sys::Array::of3(
                &js_sys::Uint8Array::from(bytes),
                &JsValue::from_f64(limits.max_entries.min(u32::MAX as usize) as f64),
                &JsValue::from_f64(limits.max_bytes as f64),
            );
            archive_from_bytes(&self.call("unzip", &args)?)
        }
    }

    pub(super) fn with<R>(f: impl FnOnce(&dyn Codecs) -> R) -> R {
        let module = STATE.with(|s| match &*s.borrow() {
            State::Ready(module) => Some(module.clone()),
            _ => None,
        });
        match &module {
            Some(module) => f(&Bridge(module)),
            None => f(&Unavailable),
        }
    }
}
