//! The page runtime: what every `<kloub-viewer>` of a page shares (one GPU device per
//! backend, recovery from its loss) and each viewer's frame on it. The element
//! (`web/kloub-viewer.js`) schedules frames (only for viewers in view that asked for one) and
//! forwards input; [`crate::Viewer`] is its handle.
//!
//! [`input`] (the full app's input, for egui), [`gesture`] (the widget build's: camera moves
//! and shortcuts) and [`a11y`] are platform-free; [`gpu`] and [`view`] exist on `wasm32` only.

#[cfg(feature = "full")]
pub mod a11y;
pub mod gesture;
#[cfg(target_arch = "wasm32")]
pub mod gpu;
#[cfg(feature = "full")]
pub mod input;
#[cfg(target_arch = "wasm32")]
pub mod log;
#[cfg(target_arch = "wasm32")]
pub mod view;
