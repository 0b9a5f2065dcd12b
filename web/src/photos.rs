//! The environment photographs (`environment-image="studio"` and `"outdoor"`:
//! [`Photo`], `web/environments/`). Natively they are embedded and read on first use. On the
//! web they stay out of the module's download: the first viewer that chooses one asks the element
//! to fetch its file from beside the module ([`set_loader`]); every viewer of the page waiting for
//! it is woken when it is in, and the decoded image is kept for the page's other viewers.
//!
//! A viewer asks with [`request`] when a page or its panel chooses a photograph, and keeps the
//! light it had until [`poll`] says the image is here (or why it is not).

use std::sync::Arc;

use crate::control::Wake;
use crate::render::environment::{HdrImage, Photo};

/// The photograph's image, if it is here: natively always (embedded), on the web once fetched.
pub fn image(photo: Photo) -> Option<Arc<HdrImage>> {
    #[cfg(target_arch = "wasm32")]
    return web::image(photo);
    #[cfg(not(target_arch = "wasm32"))]
    return native::image(photo);
}

/// Asks for `photo` (a page or a panel chose it): `Ok(true)` when it is here, `Ok(false)` while it
/// is on its way (the fetch starts unless it has already, and `wake` is called when it ends). A
/// fetch that failed is tried again.
///
/// # Errors
/// Only natively, where the embedded file cannot be read (a build error, tested).
pub fn request(photo: Photo, wake: Option<Wake>) -> Result<bool, String> {
    #[cfg(target_arch = "wasm32")]
    return Ok(web::request(photo, wake));
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = wake;
        native::image(photo).map(|_| true).ok_or_else(|| format!("{}: the embedded file is unreadable", photo.file()))
    }
}

/// Where the photograph a viewer asked for stands: `Ok(true)` here, `Ok(false)` still on its way
/// (`wake` is then called when it ends, unless it is among those waiting already: a fetch another
/// viewer started again after a failure wakes this one too).
///
/// # Errors
/// Its fetch or its file failed (the message says why; a later [`request`] tries again).
pub fn poll(photo: Photo, wake: Option<Wake>) -> Result<bool, String> {
    #[cfg(target_arch = "wasm32")]
    return web::poll(photo, wake);
    #[cfg(not(target_arch = "wasm32"))]
    request(photo, wake)
}

/// How many times the page fetched each photograph ([`Photo::ALL`]'s order): for the tests.
pub fn fetches() -> [u32; 2] {
    #[cfg(target_arch = "wasm32")]
    return web::fetches();
    #[cfg(not(target_arch = "wasm32"))]
    [0; 2]
}

/// Hands over the element's `environment(file)`: a function giving a promise of the bytes of
/// `environments/<file>` beside the module. Without one no photograph can be shown on the page.
#[cfg(target_arch = "wasm32")]
pub fn set_loader(loader: Option<js_sys::Function>) {
    web::LOADER.with(|l| *l.borrow_mut() = loader);
}

#[cfg(not(target_arch = "wasm32"))]
mod native {
    use std::sync::{Arc, OnceLock};

    use super::{HdrImage, Photo};

    static FILES: [&[u8]; 2] =
        [include_bytes!("../environments/studio.hdr"), include_bytes!("../environments/outdoor.hdr")];
    static IMAGES: [OnceLock<Option<Arc<HdrImage>>>; 2] = [OnceLock::new(), OnceLock::new()];

    pub(super) fn image(photo: Photo) -> Option<Arc<HdrImage>> {
        let i = photo.index();
        IMAGES
            .get(i)?
            .get_or_init(|| {
                FILES.get(i).and_then(|bytes| {
                    crate::render::environment::read_environment(bytes)
                        .map_err(|e| log::error!("kloub: {}: {e}", photo.file()))
                        .ok()
                        .map(Arc::new)
                })
            })
            .clone()
    }
}

#[cfg(target_arch = "wasm32")]
mod web {
    use std::cell::{Cell, RefCell};
    use std::sync::Arc;

    use wasm_bindgen::JsCast;

    use super::{HdrImage, Photo};
    use crate::control::Wake;

    /// Where one photograph is.
    enum State {
        Idle,
        Loading(Vec<Wake>),
        Ready(Arc<HdrImage>),
        Failed(String),
    }

    thread_local! {
        pub(super) static LOADER: RefCell<Option<js_sys::Function>> = const { RefCell::new(None) };
        static STATES: RefCell<[State; 2]> = const { RefCell::new([State::Idle, State::Idle]) };
        static FETCHES: Cell<[u32; 2]> = const { Cell::new([0; 2]) };
    }

    pub(super) fn image(photo: Photo) -> Option<Arc<HdrImage>> {
        STATES.with(|s| match s.borrow().get(photo.index()) {
            Some(State::Ready(image)) => Some(image.clone()),
            _ => None,
        })
    }

    pub(super) fn fetches() -> [u32; 2] {
        FETCHES.with(Cell::get)
    }

    pub(super) fn poll(photo: Photo, wake: Option<Wake>) -> Result<bool, String> {
        STATES.with(|s| match s.borrow_mut().get_mut(photo.index()) {
            Some(State::Ready(_)) => Ok(true),
            Some(State::Failed(message)) => Err(message.clone()),
            Some(State::Loading(waiting)) => {
                if let Some(wake) = wake
                    && !waiting.iter().any(|w| w.same(&wake))
                {
                    waiting.push(wake);
                }
                Ok(false)
            }
            _ => Ok(false),
        })
    }

    pub(super) fn request(photo: Photo, wake: Option<Wake>) -> bool {
        let start = STATES.with(|s| {
            let mut s = s.borrow_mut();
            // `None`: here (an index past the table cannot be: `Photo::index`).
            let state = s.get_mut(photo.index())?;
            match state {
                State::Ready(_) => None,
                State::Loading(waiting) => {
                    waiting.extend(wake);
                    Some(false)
                }
                State::Idle | State::Failed(_) => {
                    *state = State::Loading(wake.into_iter().collect());
                    Some(true)
                }
            }
        });
        match start {
            None => true,
            Some(false) => false,
            Some(true) => {
                load(photo);
                false
            }
        }
    }

    fn settle(photo: Photo, state: State) {
        let waiting = STATES.with(|s| {
            let mut s = s.borrow_mut();
            match s.get_mut(photo.index()).map(|slot| std::mem::replace(slot, state)) {
                Some(State::Loading(waiting)) => waiting,
                _ => Vec::new(),
            }
        });
        for wake in waiting {
            wake.wake();
        }
    }

    fn load(photo: Photo) {
        FETCHES.with(|n| {
            let mut all = n.get();
            if let Some(count) = all.get_mut(photo.index()) {
                *count += 1;
            }
            n.set(all);
        });
        let promise = LOADER.with(|l| {
            let missing = "this page's element does not fetch environments";
            crate::dom::loader_promise(l, &photo.file().into(), "loader", missing)
        });
        let promise = match promise {
            Ok(p) => p,
            Err(message) => return settle(photo, State::Failed(message)),
        };
        wasm_bindgen_futures::spawn_local(async move {
            let state = match wasm_bindgen_futures::JsFuture::from(promise).await {
                Ok(bytes) => match bytes.dyn_into::<js_sys::Uint8Array>() {
                    Ok(bytes) => match crate::render::environment::read_environment(&bytes.to_vec()) {
                        Ok(image) => State::Ready(Arc::new(image)),
                        Err(e) => State::Failed(format!("{}: {e}", photo.file())),
                    },
                    Err(_) => State::Failed("the element's loader gave no bytes".to_owned()),
                },
                Err(e) => State::Failed(crate::dom::js_error_text(&e)),
            };
            settle(photo, state);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_photographs_are_embedded_equirectangular_and_light_as_they_look() {
        for photo in Photo::ALL {
            assert!(request(photo, None).expect("embedded"), "{photo:?}");
            assert!(poll(photo, None).expect("embedded"));
            let image = image(photo).expect("embedded");
            assert_eq!((image.width, image.height), (256, 128), "{photo:?}");
            assert!(image.rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{photo:?}");
            // Light from above against light from below (the irradiance of a white surface facing
            // up or down): the studio's ceiling and lamps over its grey floor; an overcast sky over
            // a square's paving.
            let (up, down) = (image.irradiance([0.0, 1.0, 0.0]), image.irradiance([0.0, -1.0, 0.0]));
            let luminance = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
            eprintln!("{photo:?}: up {up:?}, down {down:?}");
            assert!(luminance(up) > 1.2 * luminance(down), "{photo:?}: up {up:?}, down {down:?}");
            if photo == Photo::Outdoor {
                // The sky is bluish, the paving red.
                assert!(up[2] > up[0], "{up:?}");
                assert!(down[0] > 1.3 * down[2], "{down:?}");
            }
        }
    }
}
