//! # kloub-core
//!
//! Kloub's animation engine. No platform code: no GPU, no DOM, no file system, no network.
//! Everything here runs the same natively and on `wasm32-unknown-unknown`.
//!
//! Walkthrough, bytes to skinned vertices:
//! 1. [`import::import`] validates a glTF/GLB document (sizes checked against a budget
//!    *before* anything is allocated) and builds an immutable [`asset::Asset`], plus warnings
//!    for defects it repaired. Errors name the JSON pointer of the offending element.
//! 2. Per frame, [`player::Player`] advances the clock; [`job::sample::SampleJob`] samples a
//!    [`clip::Clip`] into a [`pose::Pose`] (node-local TRS + morph weights);
//! 3. [`job::world::WorldJob`] turns locals into world matrices (parents before children);
//! 4. [`job::skin::PaletteJob`] multiplies joint worlds by inverse bind matrices;
//! 5. [`job::skin::LbsJob`] (CPU reference) or the GPU skins the vertices; [`job::morph::MorphJob`]
//!    applies morph targets first.
//!
//! [`instance::Instance`] bundles the buffers of steps 2–5 for one character so a frame
//! allocates nothing. [`animator::Animator`] drives it with everything beyond one clip:
//! weighted blends of several clips, crossfades, and masked or additive layers
//! ([`job::blend::BlendJob`]), again without allocating per frame.

pub mod animator;
pub mod archive;
pub mod asset;
pub mod candy;
pub mod clip;
pub mod codecs;
pub mod error;
pub mod examples;
pub mod import;
pub mod instance;
pub mod job;
pub mod math;
pub mod player;
pub mod pose;
#[cfg(feature = "physics")]
pub mod ragdoll;
pub mod rig;
pub mod sculpt;
pub mod simplify;
#[cfg(test)]
mod testutil;

pub use animator::Animator;
pub use asset::Asset;
pub use error::{ImportError, JobError, Warning};
pub use import::{ImportOptions, Imported, MapResolver, NoResolver, Resolver, import, import_with};
pub use instance::Instance;
