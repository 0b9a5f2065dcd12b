//! The `kloub` command as a library, so tests can run its parts in-process:
//! [`serve::router`] builds the HTTP application, [`pose::pose_file`] the pose JSON,
//! [`cli::run`] the whole command line.

pub mod cli;
pub mod logger;
pub mod paths;
pub mod pose;
pub mod serve;
