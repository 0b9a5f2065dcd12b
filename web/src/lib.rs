//! # kloub-web
//!
//! Kloub's viewer: an eframe app ([`app::App`]) that imports glTF/GLB with `kloub-core`,
//! plays its clips, and draws it with the wgpu [`render::SceneRenderer`] into a texture shown
//! in egui's central panel. On `wasm32` the exported [`Viewer`] runs it
//! inside a `<kloub-viewer>` element (`web/kloub-viewer.js`).
//!
//! Modules: [`app`] (frame loop, model state), [`ui`] (side panel), [`control`] (commands
//! from the page), [`load`] (fetch, drop,
//! import), [`dom`] (`document.body.dataset` mirror and error overlay; no-ops natively),
//! [`backend`] (`?backend=` choice), [`render`] (GPU renderer and camera), [`samples`] (the
//! Samples menu's library and its credits).

pub mod app;
pub mod backend;
pub mod candy;
pub mod control;
pub mod dom;
#[cfg(target_arch = "wasm32")]
mod entry;
pub mod ik;
pub mod load;
pub mod overlay;
pub mod page;
pub mod ragdoll;
pub mod render;
pub mod samples;
pub mod ui;

#[cfg(target_arch = "wasm32")]
pub use entry::Viewer;
