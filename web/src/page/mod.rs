//! The page runtime: what every `<kloub-viewer>` of a page shares (one GPU device per
//! backend, recovery from its loss) and each viewer's frame on it. The element
//! (`web/kloub-viewer.js`) schedules frames (only for viewers in view that asked for one) and
//! forwards input; [`crate::Viewer`] is its handle.
//!
//! [`input`] and [`a11y`] are platform-free; [`gpu`] and [`view`] exist on `wasm32` only.

pub mod a11y;
#[cfg(target_arch = "wasm32")]
pub mod gpu;
pub mod input;
#[cfg(target_arch = "wasm32")]
pub mod log;
#[cfg(target_arch = "wasm32")]
pub mod view;
