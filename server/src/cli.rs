//! Command-line interface of the `kloub` binary.
//!
//! ```text
//! kloub serve [--addr 127.0.0.1:8080] [--dist DIR] [--assets DIR]
//! kloub pose <file> [--clip NAME|INDEX] [--time T]... [--rest]
//! ```
//! `serve` options may also come from `KLOUB_ADDR`, `KLOUB_DIST`, `KLOUB_ASSETS` (a flag wins
//! over the variable). Without either, `--dist`/`--assets` default to `web/dist`/`web/assets`
//! of the checkout ([`crate::serve::repo_dir`]). Log level: `KLOUB_LOG` ([`crate::logger`]).

use crate::pose::{self, PoseRequest};
use crate::serve::{self, ServeConfig};
use clap::{Args, Parser, Subcommand};
use std::ffi::OsString;
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

/// Kloub: a web-served 3D character animation viewer.
#[derive(Debug, Parser)]
#[command(name = "kloub", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Sub-commands of `kloub`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Serve the viewer, the default model and the asset library over HTTP.
    Serve(ServeArgs),
    /// Print the pose of a glTF/GLB file at given times as JSON.
    Pose(PoseArgs),
}

/// Options of `kloub serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "KLOUB_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: SocketAddr,
    /// Built web bundle folder [default: web/dist of the checkout].
    #[arg(long, env = "KLOUB_DIST")]
    pub dist: Option<PathBuf>,
    /// Model library folder [default: web/assets of the checkout].
    #[arg(long, env = "KLOUB_ASSETS")]
    pub assets: Option<PathBuf>,
}

/// Options of `kloub pose`.
#[derive(Debug, Args)]
pub struct PoseArgs {
    /// The .glb or .gltf file (external files are read from its folder).
    pub file: PathBuf,
    /// Clip name or index [default: clip 0, or the rest pose when there are no clips].
    #[arg(long, value_name = "NAME|INDEX", conflicts_with = "rest")]
    pub clip: Option<String>,
    /// Time in seconds; repeat for several frames [default: 0].
    #[arg(long = "time", value_name = "T", allow_negative_numbers = true)]
    pub times: Vec<f32>,
    /// The rest pose, no clip.
    #[arg(long)]
    pub rest: bool,
}

/// Parses `args` (program name first) and runs the command. Exit code 0 on success,
/// 1 on an error (printed to stderr), 2 on a usage error.
pub fn run<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            // Prints help/version to stdout, usage errors to stderr.
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match cli.command {
        Command::Serve(args) => run_serve(args),
        Command::Pose(args) => run_pose(&args),
    }
}

fn run_serve(args: ServeArgs) -> ExitCode {
    crate::logger::init();
    let defaults = ServeConfig::default();
    let config = ServeConfig {
        dist: args.dist.unwrap_or(defaults.dist),
        assets: args.assets.unwrap_or(defaults.assets),
    };
    log::info!(
        "dist {}, assets {}",
        config.dist.display(),
        config.assets.display()
    );
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("kloub serve: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(serve::serve(&config, args.addr)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kloub serve: {}: {e}", args.addr);
            ExitCode::FAILURE
        }
    }
}

fn run_pose(args: &PoseArgs) -> ExitCode {
    let file = args.file.display();
    let request = PoseRequest {
        clip: args.clip.clone(),
        times: args.times.clone(),
        rest: args.rest,
    };
    let report = match pose::pose_file(&args.file, &request) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("kloub: {file}: {e}");
            return ExitCode::FAILURE;
        }
    };
    for w in &report.warnings {
        if w.pointer.is_empty() {
            eprintln!("warning: {file}: {}", w.message);
        } else {
            eprintln!("warning: {file}: {}: {}", w.pointer, w.message);
        }
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let written = serde_json::to_writer(&mut out, &report.doc)
        .map_err(std::io::Error::from)
        .and_then(|()| writeln!(out))
        .and_then(|()| out.flush());
    match written {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`kloub pose ... | head`): nothing left to report.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kloub: {file}: cannot write the output: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_arguments_parse() {
        let cli = Cli::try_parse_from([
            "kloub", "pose", "a.glb", "--clip", "Walk", "--time", "0.5", "--time", "-1",
        ])
        .expect("valid");
        let Command::Pose(p) = cli.command else {
            panic!("pose expected")
        };
        assert_eq!(p.file, PathBuf::from("a.glb"));
        assert_eq!(p.clip.as_deref(), Some("Walk"));
        assert_eq!(p.times, vec![0.5, -1.0]);
        assert!(!p.rest);
        assert!(Cli::try_parse_from(["kloub", "pose", "a.glb", "--rest", "--clip", "0"]).is_err());
        assert!(Cli::try_parse_from(["kloub", "pose", "a.glb", "--time", "x"]).is_err());
    }

    #[test]
    fn serve_arguments_parse() {
        let cli = Cli::try_parse_from([
            "kloub",
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--dist",
            "d",
            "--assets",
            "a",
        ])
        .expect("valid");
        let Command::Serve(s) = cli.command else {
            panic!("serve expected")
        };
        assert_eq!(s.addr, "127.0.0.1:0".parse().expect("addr"));
        assert_eq!(s.dist, Some(PathBuf::from("d")));
        assert_eq!(s.assets, Some(PathBuf::from("a")));
        assert!(Cli::try_parse_from(["kloub", "serve", "--addr", "nope"]).is_err());
    }
}
