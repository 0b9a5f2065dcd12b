//! # kloub-web
//!
//! Kloub's viewer: an egui app ([`app::App`]) that imports glTF/GLB with `kloub-core`,
//! plays its clips, and draws it with the wgpu [`render::SceneRenderer`]: in the browser straight
//! into the element's canvas under egui's output, natively (tests) into a texture egui shows. On
//! `wasm32` the exported [`Viewer`] runs it inside a `<kloub-viewer>` element
//! (`web/kloub-viewer.js`) on the page runtime ([`page`]: one GPU device for every viewer).
//!
//! Modules: [`app`] (frame loop), [`model`] (the shown model's state), [`ui`] (side panel), [`control`] (commands
//! from the page), [`load`] (fetch, drop,
//! import), [`dom`] (`document.body.dataset` mirror and error overlay; no-ops natively),
//! [`backend`] (`?backend=` choice), [`render`] (GPU renderer and camera), [`samples`] (the
//! Samples menu's library and its credits).

// Natively the widget build is only compiled (its page runtime is wasm32's): much of it unused there.
#![cfg_attr(all(not(feature = "full"), not(target_arch = "wasm32")), allow(dead_code, unused_imports))]

#[cfg(feature = "full")]
pub mod app;
pub mod backend;
pub mod candy;
pub mod codecs;
pub mod control;
pub mod decode;
pub mod dom;
#[cfg(target_arch = "wasm32")]
mod entry;
#[cfg(feature = "gl")]
pub mod gl;
pub mod ik;
pub mod load;
pub mod model;
#[cfg(feature = "full")]
pub mod overlay;
pub mod page;
pub mod photos;
#[cfg(feature = "full")]
pub mod pose;
#[cfg(target_arch = "wasm32")]
pub mod prefetch;
#[cfg(feature = "full")]
pub mod ragdoll;
pub mod render;
pub mod samples;
pub mod shared;
pub mod stage;
#[cfg(feature = "full")]
pub mod ui;
#[cfg(feature = "full")]
pub mod validation;

#[cfg(target_arch = "wasm32")]
pub use entry::Viewer;
