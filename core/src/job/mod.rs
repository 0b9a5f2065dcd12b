//! Per-frame jobs in the ozz-animation style: each job borrows its inputs, writes into a
//! caller-owned output slice, checks its inputs in `validate()` and does the work in
//! `run()` (which validates first). Jobs never allocate.
//!
//! - [`sample::SampleJob`]: clip at a time → node-local transforms and morph weights;
//! - [`blend::BlendJob`]: several poses → one (weighted average, override, additive layers);
//! - [`world::WorldJob`]: locals → world matrices;
//! - [`skin::PaletteJob`]: world matrices → skinning palette;
//! - [`morph::MorphJob`]: base + weighted morph deltas;
//! - [`skin::LbsJob`]: linear blend skinning of positions and normals (CPU reference);
//! - [`dqs::DqPrepareJob`] + [`dqs::DqsJob`]: dual-quaternion skinning; [`dqs::RigidJob`]: strongest
//!   influence only; [`sjb::SjbPlan`] + [`sjb::SjbJob`]: spherical joint blending;
//! - [`sjbbe::SjbbeRig`] + [`sjbbe::SjbbeAlphaJob`] + [`sjbbe::SjbbeJob`]: SJB by example poses (§5.3);
//! - [`ik::IkJob`]: inverse kinematics on the blended pose (CCD, two-bone) with joint limits.

pub mod blend;
pub mod dqs;
pub mod ik;
pub(crate) mod lanes;
pub mod morph;
pub mod sample;
pub mod sjb;
pub mod sjbbe;
pub mod skin;
pub mod world;

use crate::error::JobError;

/// The joint of a vertex's strongest influence (the first of equals); `None` without a positive
/// weight. Rigid skinning follows it; the shadow casters' clustering groups vertices by it.
pub(crate) fn strongest_joint(joints: &[u16; 8], weights: &[f32; 8]) -> Option<u16> {
    let mut best: Option<(u16, f32)> = None;
    for (&j, &w) in joints.iter().zip(weights) {
        if w > 0.0 && best.is_none_or(|(_, b)| w > b) {
            best = Some((j, w));
        }
    }
    best.map(|(j, _)| j)
}

/// `Err(BufferTooSmall)` when `got < needed`.
pub(crate) fn check_len(what: &'static str, needed: usize, got: usize) -> Result<(), JobError> {
    if got < needed { Err(JobError::BufferTooSmall { what, needed, got }) } else { Ok(()) }
}

/// `Err(LengthMismatch)` when `got != expected`.
pub(crate) fn check_eq(what: &'static str, expected: usize, got: usize) -> Result<(), JobError> {
    if got != expected { Err(JobError::LengthMismatch { what, expected, got }) } else { Ok(()) }
}

/// `Err(IndexOutOfRange)` when `index >= len`.
pub(crate) fn check_index(what: &'static str, index: usize, len: usize) -> Result<(), JobError> {
    if index >= len { Err(JobError::IndexOutOfRange { what, index, len }) } else { Ok(()) }
}
