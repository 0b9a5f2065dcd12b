//! Kloub's wgpu renderer: one code path for the app (WebGPU, WebGL2, native) and the
//! headless golden-image tests.
//!
//! # Frame flow
//! ```text
//! Asset ──set_asset──▶ SceneRenderer: vertex streams per primitive, sRGB textures + mips,
//!                       material uniforms, palette texture for all skins, draw list
//! Instance (evaluated by the caller: clip + time → worlds, palettes)
//!        ──render────▶ palette texture + per-draw uniforms updated, one render pass:
//!                       background → opaque meshes → ground grid → blended meshes (back to front)
//!                       into the renderer's own Rgba8UnormSrgb target (4× MSAA resolved)
//!                       → egui image (app) or readback (tests)
//! ```
//!
//! # Using it in the app (eframe + egui_wgpu)
//! ```text
//! let state = frame.wgpu_render_state().unwrap();          // eframe::egui_wgpu::RenderState
//! let mut renderer = SceneRenderer::new(&state.device, &state.queue, msaa_samples(&state.adapter));
//! renderer.set_asset(&state.device, &state.queue, &asset)?;  // on every model load
//! // each frame:
//! instance.evaluate(&asset, player.clip, player.time)?;
//! let view = renderer.render(&state.device, &state.queue, &asset, &mut instance, &camera, [w, h])?;
//! // register once, and again whenever renderer.target_version() changes:
//! let mut egui_renderer = state.renderer.write();
//! egui_renderer.update_egui_texture_from_wgpu_texture(&state.device, view, wgpu::FilterMode::Linear, id);
//! // (first time: id = egui_renderer.register_native_texture(&state.device, view, wgpu::FilterMode::Linear))
//! ui.image((id, egui::vec2(w as f32 / ppp, h as f32 / ppp)));
//! ```
//! The target is `Rgba8UnormSrgb`: egui samples it as linear colour, so gamma is handled by
//! the texture format on every backend (the web surface's `Rgba8Unorm` does not matter).
//! Camera input: [`Camera::orbit_pixels`] (drag), [`Camera::pan_pixels`] (secondary drag),
//! [`Camera::zoom_scroll`] (wheel), [`Camera::frame_to_fit`] with
//! [`kloub_core::Instance::scene_bounds`] after loading.
//!
//! # Deformation
//! Skinned primitives are skinned in the vertex shader (`vs_skinned` in `shaders/mesh.wgsl`):
//! linear blend skinning with the matrices blended first, up to 8 influences, the palette
//! read from an `rgba32float` texture ([`palette`]) so it works on WebGL2. Primitives with
//! morph targets, and every skinned primitive under [`SkinningPath::Cpu`], are deformed by
//! `kloub_core`'s CPU reference and their geometry stream is rewritten each frame.
//! The geometry stream (position + normal) is kept separate from the other attributes so a
//! later compute-skinning pass can write it once per frame for every draw.
//!
//! # Headless
//! [`offscreen::render_to_image`] (native only) renders through the same [`SceneRenderer`]
//! and reads the pixels back; [`offscreen::Offscreen`] keeps the device for several frames.

pub mod camera;
pub mod environment;
pub mod mesh;
pub mod morph;
#[cfg(not(target_arch = "wasm32"))]
pub mod offscreen;
pub mod palette;
pub mod pipelines;
pub mod readback;
pub mod scene;
pub mod texture;
pub mod uniforms;

pub use camera::Camera;
pub use scene::{
    RenderTimes, SceneRenderer, SculptMesh, SkinningPath, default_skinning_path, display_msaa, msaa_samples,
    scene_format,
};
pub use uniforms::Ground;
