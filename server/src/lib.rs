//! The `kloub` command as a library, so tests can run its parts in-process:
//! [`serve::App`] answers HTTP requests, [`pose::pose_file`] the pose JSON,
//! [`inspect::inspect_file`] the description of a file,
//! [`cli::run`] the whole command line.

pub mod cli;
pub mod ik;
pub mod inspect;
pub mod logger;
pub mod paths;
pub mod pose;
pub mod ragdoll;
pub mod serve;
