//! Kloub's own WebGL2 backend for wgpu (its custom-backend interface): the renderer's wgpu calls
//! run on a WebGL2 context without wgpu's GL layer or a shader compiler in the module.
//!
//! wgpu's WebGL2 support translates WGSL to GLSL in the page (naga) and validates every call
//! (wgpu-core): 1.7 MB of the 2.9 MB WebGL2 widget (BENCHMARKS.md, "Widget size"), which a
//! browser without WebGPU downloaded before its first frame. Here the shaders are translated when
//! the crate is built (`web/build.rs`, [`table`]) and the calls go straight to WebGL2, only
//! those the renderer makes being implemented (what WebGL2 cannot do — compute, queries, bundles —
//! is an error through the device's error handler, as wgpu's WebGL2 reports it).
//!
//! - `table`: the translated GLSL and what each program binds (platform-free, tested natively);
//! - `wasm` (wasm32): the instance, adapter, device, queue and surface; `state`, the context and
//!   its GL objects (wgpu's objects are handles into them); `resources`, buffers, textures,
//!   samplers, bind groups, pipelines; `shaders`, programs linked and checked; `commands`,
//!   encoders and passes record and the queue runs them on submit.
//!
//! Orientation: what is drawn into textures lies in memory as WebGPU's does (the shaders flip Y,
//! as wgpu's GL layer does); what is drawn into the canvas is drawn unflipped, so presenting is
//! the browser's alone (wgpu's GL layer draws into a texture and blits it into the canvas with a
//! flip every frame).

pub mod hash;

/// What starts a module's source that is only its key (`render::pipelines::shader_source!`): a WGSL
/// comment, then the key in hex.
pub const KEYED: &str = "// kloub glsl ";
#[cfg_attr(
    not(target_arch = "wasm32"),
    allow(dead_code, reason = "read by the wasm backend; natively only by the tests")
)]
mod table;
#[cfg(target_arch = "wasm32")]
mod wasm;

#[cfg(target_arch = "wasm32")]
pub use wasm::instance;
