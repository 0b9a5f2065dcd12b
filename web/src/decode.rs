//! Images the importer kept encoded ([`kloub_core::asset::Image::encoded`]: the web builds
//! import without the `images` feature), decoded by the browser: `createImageBitmap` off the
//! main thread, not premultiplied, no colour conversion. A model waits for its images before it
//! is shown ([`ready`]); the texture upload then copies each bitmap into the GPU
//! ([`crate::render::texture::upload_bitmap`]), so decoded pixels never pass through the wasm
//! heap and no decoder is part of the download.
//!
//! Decoding happens once per asset and page: every viewer showing the asset (one download
//! shared by URL, [`crate::shared`]) waits for the same bitmaps. Natively the importer decodes
//! (the `images` feature), so every asset is ready at once.

use std::sync::Arc;

use kloub_core::{Asset, Warning};

use crate::control::Wake;

/// Whether `asset`'s images can be uploaded: none is encoded, or the browser has decoded them
/// all (or given up on some: [`warnings`]). When not, decoding starts (once per asset), no
/// image larger than `max_size` on a side (halved until it fits, like the mip levels the CPU
/// path skips), and `wake` is called when it is done. `url`: where the asset came from; the
/// bitmaps the element decoded from its download while the module loaded
/// ([`crate::prefetch::take_images`]) are taken where they have the size asked for.
#[cfg(target_arch = "wasm32")]
pub fn ready(asset: &Arc<Asset>, max_size: u32, wake: Option<Wake>, url: Option<&str>) -> bool {
    web::ready(asset, max_size, wake, url)
}

/// Natively the importer decodes: always ready.
#[cfg(not(target_arch = "wasm32"))]
pub fn ready(_asset: &Arc<Asset>, _max_size: u32, _wake: Option<Wake>, _url: Option<&str>) -> bool {
    true
}

/// What went wrong decoding `asset`'s images: one warning per image the browser could not
/// decode (drawn white, as the importer does with a file it cannot read).
#[cfg(target_arch = "wasm32")]
pub fn warnings(asset: &Asset) -> Vec<Warning> {
    web::warnings(asset)
}

/// Natively nothing is decoded here.
#[cfg(not(target_arch = "wasm32"))]
pub fn warnings(_asset: &Asset) -> Vec<Warning> {
    Vec::new()
}

#[cfg(target_arch = "wasm32")]
pub use web::bitmap;

/// How many bitmaps were taken from the element's prefetch (decoded while the module loaded)
/// on this thread: for the tests.
#[cfg(target_arch = "wasm32")]
pub fn predecoded() -> usize {
    web::PREDECODED.with(|n| n.get())
}

/// Lets `derived` (an asset made from `base`, with the same images: the example poses' morph
/// targets added) use `base`'s decoded bitmaps; `base` keeps them (closing them when it goes).
pub fn share(base: &Arc<Asset>, derived: &Arc<Asset>) {
    #[cfg(target_arch = "wasm32")]
    web::share(base, derived);
    #[cfg(not(target_arch = "wasm32"))]
    let _ = (base, derived);
}

/// Lets the bitmaps of assets no viewer shows any more go (closed at once, not left to the
/// garbage collector): with [`crate::render::scene::release_unused_uploads`].
pub fn release_unused() {
    #[cfg(target_arch = "wasm32")]
    web::release_unused();
}

/// A size halved until neither side exceeds `max` (at least 1×1).
pub fn fit(mut width: u32, mut height: u32, max: u32) -> (u32, u32) {
    while width > max.max(1) || height > max.max(1) {
        width = (width / 2).max(1);
        height = (height / 2).max(1);
    }
    (width, height)
}

#[cfg(target_arch = "wasm32")]
mod web {
    use std::cell::RefCell;
    use std::sync::{Arc, Weak};

    use kloub_core::asset::EncodedImage;
    use kloub_core::{Asset, Warning};
    use wasm_bindgen::JsCast;

    use crate::prefetch::EarlyImages;

    use crate::control::Wake;
    use crate::dom::js_error_text;

    /// One asset's images.
    struct Entry {
        asset: Weak<Asset>,
        /// Per image, once decoding is done: the bitmap (`None`: not encoded, or undecodable).
        bitmaps: Option<Vec<Option<web_sys::ImageBitmap>>>,
        warnings: Vec<Warning>,
        /// Viewers waiting for the bitmaps.
        waiting: Vec<Wake>,
        /// Whether the bitmaps are this entry's to close (not another asset's, [`share`]d).
        owns: bool,
    }

    thread_local! {
        static ENTRIES: RefCell<Vec<Entry>> = const { RefCell::new(Vec::new()) };
        pub static PREDECODED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    }

    fn find<T>(asset: &Asset, f: impl FnOnce(&mut Entry) -> T) -> Option<T> {
        release_unused();
        ENTRIES.with(|entries| entries.borrow_mut().iter_mut().find(|e| std::ptr::eq(e.asset.as_ptr(), asset)).map(f))
    }

    pub fn share(base: &Arc<Asset>, derived: &Arc<Asset>) {
        let Some((bitmaps, warnings)) = find(base, |e| (e.bitmaps.clone(), e.warnings.clone())) else { return };
        ENTRIES.with(|entries| {
            entries.borrow_mut().push(Entry {
                asset: Arc::downgrade(derived),
                bitmaps,
                warnings,
                waiting: Vec::new(),
                owns: false,
            });
        });
    }

    pub fn release_unused() {
        ENTRIES.with(|entries| {
            entries.borrow_mut().retain(|e| {
                let alive = e.asset.strong_count() > 0;
                if !alive && e.owns {
                    for bitmap in e.bitmaps.iter().flatten().flatten() {
                        bitmap.close();
                    }
                }
                alive
            });
        });
    }

    pub fn ready(asset: &Arc<Asset>, max_size: u32, wake: Option<Wake>, url: Option<&str>) -> bool {
        if asset.images.iter().all(|i| i.encoded.is_none()) {
            return true;
        }
        let known = find(asset, |entry| {
            let done = entry.bitmaps.is_some();
            if !done && let Some(wake) = wake.clone() {
                entry.waiting.push(wake);
            }
            done
        });
        match known {
            Some(done) => done,
            None => {
                ENTRIES.with(|entries| {
                    entries.borrow_mut().push(Entry {
                        asset: Arc::downgrade(asset),
                        bitmaps: None,
                        warnings: Vec::new(),
                        waiting: wake.into_iter().collect(),
                        owns: true,
                    });
                });
                let asset = asset.clone();
                let pending = match url.and_then(crate::prefetch::take_images) {
                    Some(EarlyImages::Decoding(promise)) => Err(promise),
                    Some(EarlyImages::Decoded(early)) => Ok(hand_over(&asset, early, max_size)),
                    None => Ok(hand_over(&asset, Vec::new(), max_size)),
                };
                // Every image decoded already (by the element, at the size asked for): ready in
                // this frame.
                if let Ok(pending) = &pending
                    && pending.iter().flatten().all(|p| matches!(p, Pending::Decoded(_)))
                {
                    let bitmaps = pending
                        .iter()
                        .map(|p| match p {
                            Some(Pending::Decoded(bitmap)) => Some(bitmap.clone()),
                            _ => None,
                        })
                        .collect();
                    find(&asset, |entry| {
                        entry.bitmaps = Some(bitmaps);
                        entry.waiting.clear();
                    });
                    return true;
                }
                wasm_bindgen_futures::spawn_local(async move {
                    let pending = match pending {
                        Ok(pending) => pending,
                        Err(promise) => {
                            let early = wasm_bindgen_futures::JsFuture::from(promise).await;
                            hand_over(&asset, early.map(crate::prefetch::bitmaps).unwrap_or_default(), max_size)
                        }
                    };
                    let mut bitmaps = Vec::with_capacity(asset.images.len());
                    let mut warnings = Vec::new();
                    for (i, pending) in pending.into_iter().enumerate() {
                        let result = match pending {
                            None => {
                                bitmaps.push(None);
                                continue;
                            }
                            Some(Pending::Decoded(bitmap)) => Ok(bitmap),
                            Some(Pending::Decoding(promise)) => finish(promise).await,
                        };
                        match result {
                            Ok(bitmap) => bitmaps.push(Some(bitmap)),
                            Err(e) => {
                                warnings.push(Warning::new(
                                    format!("/images/{i}"),
                                    format!("the browser cannot decode this image ({e}); image skipped (drawn white)"),
                                ));
                                bitmaps.push(None);
                            }
                        }
                    }
                    let waiting = find(&asset, |entry| {
                        entry.bitmaps = Some(bitmaps);
                        entry.warnings = warnings;
                        std::mem::take(&mut entry.waiting)
                    });
                    for wake in waiting.into_iter().flatten() {
                        wake.wake();
                    }
                });
                false
            }
        }
    }

    pub fn warnings(asset: &Asset) -> Vec<Warning> {
        find(asset, |e| e.warnings.clone()).unwrap_or_default()
    }

    /// The browser's bitmap of image `image` of `asset`, once decoded.
    pub fn bitmap(asset: &Asset, image: usize) -> Option<web_sys::ImageBitmap> {
        find(asset, |e| e.bitmaps.as_ref().and_then(|b| b.get(image).cloned().flatten())).flatten()
    }

    /// Each encoded image of `asset` on its way to a bitmap: the one the element decoded while the
    /// module loaded (`early`, per image) where it has the size asked for, else handed to the
    /// browser's decoder now (all first, so that they decode in parallel); the early bitmaps not
    /// taken are closed.
    fn hand_over(asset: &Asset, mut early: Vec<Option<web_sys::ImageBitmap>>, max_size: u32) -> Vec<Option<Pending>> {
        let pending = asset
            .images
            .iter()
            .enumerate()
            .map(|(i, image)| {
                let encoded = image.encoded.as_ref()?;
                let size = super::fit(image.width, image.height, max_size);
                let slot = early.get_mut(i);
                if let Some(bitmap) = slot.and_then(|b| b.take_if(|b| (b.width(), b.height()) == size)) {
                    PREDECODED.with(|n| n.set(n.get() + 1));
                    return Some(Pending::Decoded(bitmap));
                }
                Some(Pending::Decoding(start(encoded, image.width, image.height, max_size)))
            })
            .collect();
        for bitmap in early.into_iter().flatten() {
            bitmap.close();
        }
        pending
    }

    /// An image on its way to a bitmap.
    enum Pending {
        /// Decoded while the module loaded (the element's prefetch).
        Decoded(web_sys::ImageBitmap),
        /// Handed to the browser's decoder here.
        Decoding(Result<js_sys::Promise, String>),
    }

    /// Hands the file to the browser's decoder.
    fn start(image: &EncodedImage, width: u32, height: u32, max_size: u32) -> Result<js_sys::Promise, String> {
        let window = web_sys::window().ok_or("no window")?;
        let parts = js_sys::Array::of1(&js_sys::Uint8Array::from(image.bytes.as_slice()));
        let bag = web_sys::BlobPropertyBag::new();
        bag.set_type(image.format.mime());
        let blob =
            web_sys::Blob::new_with_u8_array_sequence_and_options(&parts, &bag).map_err(|e| js_error_text(&e))?;
        let options = web_sys::ImageBitmapOptions::new();
        options.set_premultiply_alpha(web_sys::PremultiplyAlpha::None);
        options.set_color_space_conversion(web_sys::ColorSpaceConversion::None);
        let (fit_width, fit_height) = super::fit(width, height, max_size);
        if (fit_width, fit_height) != (width, height) {
            options.set_resize_width(fit_width);
            options.set_resize_height(fit_height);
            options.set_resize_quality(web_sys::ResizeQuality::High);
        }
        window.create_image_bitmap_with_blob_and_image_bitmap_options(&blob, &options).map_err(|e| js_error_text(&e))
    }

    async fn finish(promise: Result<js_sys::Promise, String>) -> Result<web_sys::ImageBitmap, String> {
        let value = wasm_bindgen_futures::JsFuture::from(promise?).await.map_err(|e| js_error_text(&e))?;
        value.dyn_into::<web_sys::ImageBitmap>().map_err(|_| "not an image bitmap".to_owned())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn sizes_halve_until_they_fit() {
        assert_eq!(super::fit(1024, 512, 2048), (1024, 512));
        assert_eq!(super::fit(8192, 1000, 2048), (2048, 250));
        assert_eq!(super::fit(3, 9000, 2048), (1, 1125));
        assert_eq!(super::fit(5, 5, 0), (1, 1));
    }
}
