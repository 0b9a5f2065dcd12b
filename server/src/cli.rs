//! Command-line interface of the `kloub` binary.
//!
//! ```text
//! kloub serve [--addr 127.0.0.1:8080] [--dist DIR] [--assets DIR]
//! kloub pose <file> [--clip NAME|INDEX] [--time T]... [--rest]
//!            [--crossfade FROM:TO:DURATION [--at T] [--easing E] [--outgoing O]]
//!            [--layer CLIP:ROOT_JOINT:WEIGHT]... [--layer-falloff F] [--layer-additive]
//! kloub inspect <file> [--json]
//! ```
//! `serve` options may also come from `KLOUB_ADDR`, `KLOUB_DIST`, `KLOUB_ASSETS`,
//! `KLOUB_MAX_CONNECTIONS` (a flag wins over the variable). Without `--dist`/`--assets`, the web
//! bundle and the samples embedded in the binary at build time are served
//! ([`crate::serve::embedded`]). Log level: `KLOUB_LOG` ([`crate::logger`]).

use crate::inspect;
use crate::pose::{self, CrossfadeRequest, LayerRequest, PoseRequest};
use crate::serve::listen::DEFAULT_MAX_CONNECTIONS;
use crate::serve::{self, App, Limits, ServeConfig, Source};
use clap::{Args, Parser, Subcommand, ValueEnum};
use kloub_core::animator::{Easing, Outgoing};
use kloub_core::job::dqs::SkinningMethod;
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
    #[command(long_about = POSE_HELP)]
    Pose(PoseArgs),
    /// Describe a glTF/GLB file: scenes, skins, clips, morph targets, import warnings.
    #[command(after_long_help = INSPECT_HELP)]
    Inspect(InspectArgs),
    /// Bring an end effector to a target by inverse kinematics and print the chain as JSON.
    Ik(IkArgs),
    /// Drop a posed file as a ragdoll and print its joints' world positions every 1/60 s as JSON.
    Ragdoll(RagdollArgs),
}

/// A file posed by a clip at a time (the rest pose without a clip): what `kloub ik` and
/// `kloub ragdoll` start from.
#[derive(Debug, clap::Args)]
pub struct PosedFile {
    /// The glTF/GLB file.
    pub file: std::path::PathBuf,
    /// Pose with this clip (name or index) first; the rest pose without.
    #[arg(long)]
    pub clip: Option<String>,
    /// Time in the clip, seconds.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
}

/// `kloub ragdoll` arguments.
#[derive(Debug, clap::Args)]
pub struct RagdollArgs {
    /// The file and its pose.
    #[command(flatten)]
    pub posed: PosedFile,
    /// Seconds to simulate (60 frames each).
    #[arg(long)]
    pub seconds: f32,
    /// Obstacles to fall on: a JSON array of boxes, spheres, capsules, stairs and ramps in model
    /// units (see the README).
    #[arg(long, value_name = "FILE.json")]
    pub obstacles: Option<PathBuf>,
    /// Powered ragdoll: 0 (limp, the default) to 1 (the bodies follow the clip from `--time` on,
    /// as the viewer's strength slider).
    #[arg(long, default_value_t = 0.0)]
    pub strength: f32,
    /// Print JSON (the only format; accepted for symmetry with the other commands).
    #[arg(long)]
    pub json: bool,
}

/// `kloub ik` arguments.
#[derive(Debug, clap::Args)]
pub struct IkArgs {
    /// The file and its pose.
    #[command(flatten)]
    pub posed: PosedFile,
    /// End effector: a joint (node) name or index.
    #[arg(long)]
    pub effector: String,
    /// Joints above the effector that rotate.
    #[arg(long)]
    pub depth: usize,
    /// Target in world space: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: [f32; 3],
    /// Solver.
    #[arg(long, value_enum, default_value_t = IkSolverArg::Ccd)]
    pub solver: IkSolverArg,
    /// Most iterations (CCD sweeps, FABRIK passes).
    #[arg(long, default_value_t = 32)]
    pub iterations: u32,
    /// Stop within this distance of the target (world units).
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f32,
    /// CCD as seed 000 has it, without the pattern move after each sweep (slow near full reach).
    #[arg(long)]
    pub plain_ccd: bool,
    /// Two-bone: soft reach, the last F × chain length of reach approached smoothly (0 ≤ F < 1).
    #[arg(long, default_value_t = 0.0, value_name = "F")]
    pub soft: f32,
    /// Two-bone: bend the middle joint towards this world point x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub pole: Option<[f32; 3]>,
    /// CCD stiffness per rotating joint, root first, comma-separated in [0, 1].
    #[arg(long, value_delimiter = ',')]
    pub stiffness: Vec<f32>,
    /// Respect joint limits inferred from humanoid joint names (hinge elbows and knees, ball
    /// shoulders and hips).
    #[arg(long)]
    pub humanoid_limits: bool,
    /// A `<model>.kloub.json` sidecar: joint limits and stiffness over the humanoid defaults
    /// (implies --humanoid-limits).
    #[arg(long, value_name = "FILE")]
    pub limits: Option<std::path::PathBuf>,
}

/// `--solver` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IkSolverArg {
    /// Cyclic coordinate descent (seed 000 eqs. 3.21–3.24).
    Ccd,
    /// Analytic two-bone (depth 2) with an optional pole.
    Twobone,
    /// FABRIK.
    Fabrik,
    /// Damped least squares on the Jacobian (Buss).
    Dls,
}

fn parse_vec3(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("{s:?}: expected x,y,z"));
    };
    let num =
        |p: &str| p.trim().parse::<f32>().ok().filter(|v| v.is_finite()).ok_or(format!("{p:?} is not a finite number"));
    Ok([num(x)?, num(y)?, num(z)?])
}

const POSE_HELP: &str = "\
Print the pose of a glTF/GLB file at given times as JSON: world matrices of every node, \
morph weights, and the deformed (morphed, skinned) world-space positions of every primitive \
of the default scene.

Without --crossfade/--layer, each --time samples the clip directly (clamped to its duration).

Blending: with --crossfade or --layer the pose comes from the viewer's animator. Every clip \
plays on its own looping clock from time 0 at speed 1, and each --time is absolute from that \
start (times must be >= 0; each is computed from the start, independently of the others).
  --crossfade FROM:TO:DURATION  FROM plays from 0; at --at seconds the base crossfades to TO \
over DURATION seconds (TO starts at its time 0, or in step with FROM for --outgoing sync).
  --layer CLIP:ROOT_JOINT:WEIGHT  CLIP overrides (or, with --layer-additive, adds its motion \
relative to its first frame to) the subtree under ROOT_JOINT, with WEIGHT and a per-generation \
falloff: a joint d generations below the root gets WEIGHT * (1 - F)^d. Layers apply in order \
on top of the base (--clip, or the crossfade).
Clips are named or indexed; joints are named (skin joints first, then any node) or given by \
node index; names may contain ':'. `kloub inspect FILE` lists both.

The JSON then also has \"crossfade\": {from, to, duration, at, easing, outgoing} and \
\"layers\": [{clip, root: {index, name}, weight, falloff, additive}] (absent otherwise).";

const INSPECT_HELP: &str = "\
JSON keys (--json), stable:
  asset, default_scene (index|null),
  nodes[]:   index, name, parent (node|null), mesh (index|null), skin (index|null)
  scenes[]:  index, name, roots[] (node indices)
  skins[]:   index, name, skeleton (node|null),
             joints[]: joint, node, name, parent (node|null), parent_joint (joint|null), depth
  clips[]:   index, name, duration (s), channel_count,
             channels[]: node, node_name, path (translation|rotation|scale|weights),
                         interpolation (STEP|LINEAR|CUBICSPLINE), keys, start, end (s)
  meshes[]:  index, name, primitives, vertices, nodes[] (instancing nodes), morph_targets,
             target_names[]
  images[]:  index, name, width, height, decoded_bytes (RGBA8, before mips)
  extensions_used[], extensions_required[] (the file's extension names)
  compressed_views[]: view, extension, mode, filter, compressed_bytes, decoded_bytes
             (buffer views stored with EXT_/KHR_meshopt_compression, and what decoding cost)
  compressed_primitives[]: mesh, primitive, view, extension, compressed_bytes, decoded_bytes,
             points, triangles (primitives stored with KHR_draco_mesh_compression)
  warnings[]: pointer (JSON pointer), message
Names are null when the file has none.";

/// Options of `kloub serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "KLOUB_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: SocketAddr,
    /// Serve the web bundle from this folder [default: the bundle embedded in the binary].
    #[arg(long, env = "KLOUB_DIST")]
    pub dist: Option<PathBuf>,
    /// Serve the sample library from this folder [default: the samples embedded in the binary].
    #[arg(long, env = "KLOUB_ASSETS")]
    pub assets: Option<PathBuf>,
    /// Most connections served at once (more wait in the listen backlog).
    #[arg(long, env = "KLOUB_MAX_CONNECTIONS", default_value_t = DEFAULT_MAX_CONNECTIONS,
          value_parser = clap::value_parser!(u32).range(1..=1_048_576))]
    pub max_connections: u32,
    /// Origins the page may open models from besides this server: CSP `connect-src` sources,
    /// space-separated (e.g. "https://cdn.example.com"; "" for this server only)
    /// [default: "https: http://127.0.0.1:* http://localhost:*"].
    #[arg(long, env = "KLOUB_CONNECT_SRC", value_name = "SOURCES", value_parser = parse_connect_src)]
    pub connect_src: Option<String>,
}

/// Checks `--connect-src` (see [`crate::serve::csp`]).
fn parse_connect_src(sources: &str) -> Result<String, String> {
    crate::serve::csp(sources).map(|_| sources.to_owned())
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
    /// Crossfade from clip FROM to clip TO over DURATION seconds, starting at --at.
    #[arg(long, value_name = "FROM:TO:DURATION", conflicts_with_all = ["clip", "rest"])]
    pub crossfade: Option<String>,
    /// When the crossfade starts, in seconds from the start.
    #[arg(long, value_name = "T", default_value_t = 0.0, requires = "crossfade")]
    pub at: f32,
    /// Crossfade progress curve.
    #[arg(long, value_enum, default_value_t = EasingArg::Smoothstep, requires = "crossfade")]
    pub easing: EasingArg,
    /// What the outgoing clip does during the crossfade.
    #[arg(long, value_enum, default_value_t = OutgoingArg::Freeze, requires = "crossfade")]
    pub outgoing: OutgoingArg,
    /// A clip on the subtree under a joint, with a weight; repeat for several layers.
    #[arg(long = "layer", value_name = "CLIP:ROOT_JOINT:WEIGHT")]
    pub layers: Vec<String>,
    /// Per-generation weight falloff of every layer, in [0, 1].
    #[arg(long, value_name = "F", default_value_t = 0.0, requires = "layers")]
    pub layer_falloff: f32,
    /// Layers add their motion (relative to their first frame) instead of overriding.
    #[arg(long, requires = "layers")]
    pub layer_additive: bool,
    /// How skinned vertices follow their joints.
    #[arg(long, value_enum, default_value_t = SkinningArg::Lbs)]
    pub skinning: SkinningArg,
    /// A `<model>.kloub.json` sidecar whose `examples` (example poses) shape `--skinning sjbbe`.
    #[arg(long, value_name = "FILE.kloub.json")]
    pub examples: Option<PathBuf>,
    /// Sets JOINT's local rotation (a unit quaternion) after the clip is sampled; repeatable.
    /// JOINT is a node name or index.
    #[arg(long = "rotate", value_name = "JOINT:x,y,z,w", allow_hyphen_values = true)]
    pub rotations: Vec<String>,
}

/// `--skinning` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SkinningArg {
    /// The strongest influence only.
    Rigid,
    /// Linear blend skinning (the glTF reference).
    Lbs,
    /// Dual-quaternion skinning (no candy-wrapper collapse).
    Dqs,
    /// Spherical joint blending (rotation about the joint centre; dual quaternions where the
    /// influences do not share one).
    Sjb,
    /// Spherical joint blending by example: SJB after the example poses of `--examples`.
    Sjbbe,
}

/// `--easing` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EasingArg {
    /// Constant rate.
    Linear,
    /// 3u² − 2u³: gentle start and end.
    Smoothstep,
}

/// `--outgoing` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutgoingArg {
    /// Blend from the pose at the moment the crossfade starts.
    Freeze,
    /// FROM keeps playing while it fades out.
    Keep,
    /// As keep, and TO starts at FROM's normalized time.
    Sync,
}

/// Options of `kloub inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// The .glb or .gltf file (external files are read from its folder).
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
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
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    match cli.command {
        Command::Serve(args) => run_serve(args),
        Command::Pose(args) => run_pose(&args),
        Command::Inspect(args) => run_inspect(&args),
        Command::Ik(args) => run_ik(&args),
        Command::Ragdoll(args) => run_ragdoll(&args),
    }
}

fn run_ragdoll(args: &RagdollArgs) -> ExitCode {
    let posed = &args.posed;
    let file = posed.file.display().to_string();
    let world = crate::ragdoll::RagdollWorld {
        seconds: args.seconds,
        obstacles: args.obstacles.clone(),
        strength: args.strength,
    };
    print_json(&file, crate::ragdoll::ragdoll_file(&posed.file, posed.clip.as_deref(), posed.time, &world))
}

/// Prints a command's document as one line of JSON, or its error naming `file` (exit 1).
fn print_json<T: serde::Serialize, E: std::fmt::Display>(file: &str, result: Result<T, E>) -> ExitCode {
    match result {
        Ok(doc) => write_stdout(file, |out| {
            serde_json::to_writer(&mut *out, &doc).map_err(std::io::Error::from)?;
            writeln!(out)
        }),
        Err(e) => {
            eprintln!("kloub: {file}: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_ik(args: &IkArgs) -> ExitCode {
    let file = args.posed.file.display().to_string();
    let sidecar = match &args.limits {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(text) => Some(text),
            Err(e) => {
                eprintln!("kloub: {}: cannot read: {e}", path.display());
                return ExitCode::FAILURE;
            }
        },
        None => None,
    };
    let request = crate::ik::IkRequest {
        clip: args.posed.clip.clone(),
        time: args.posed.time,
        effector: args.effector.clone(),
        depth: args.depth,
        target: args.target,
        pole: args.pole,
        stiffness: args.stiffness.clone(),
        humanoid_limits: args.humanoid_limits || sidecar.is_some(),
        sidecar,
        settings: kloub_core::job::ik::IkSettings {
            solver: match args.solver {
                IkSolverArg::Ccd => kloub_core::job::ik::IkSolver::Ccd,
                IkSolverArg::Twobone => kloub_core::job::ik::IkSolver::TwoBone,
                IkSolverArg::Fabrik => kloub_core::job::ik::IkSolver::Fabrik,
                IkSolverArg::Dls => kloub_core::job::ik::IkSolver::Dls,
            },
            iterations: args.iterations,
            tolerance: args.tolerance,
            weight: 1.0,
            accelerate: !args.plain_ccd,
            softness: args.soft,
        },
    };
    print_json(&file, crate::ik::ik_file(&args.posed.file, &request))
}

fn run_serve(args: ServeArgs) -> ExitCode {
    crate::logger::init();
    let defaults = ServeConfig::default();
    let describe = |source: &Source| match source {
        Source::Dir(d) => d.display().to_string(),
        Source::Memory(m) => format!("embedded ({} files)", m.len()),
    };
    let config = ServeConfig {
        dist: args.dist.map_or(defaults.dist, Source::Dir),
        assets: args.assets.map_or(defaults.assets, Source::Dir),
        limits: Limits { max_connections: args.max_connections as usize, ..defaults.limits },
        connect_src: args.connect_src,
    };
    log::info!("web bundle: {}; samples: {}", describe(&config.dist), describe(&config.assets));
    let app = App::new(&config);
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("kloub serve: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(serve::serve(app, args.addr)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("kloub serve: {}: {e}", args.addr);
            ExitCode::FAILURE
        }
    }
}

fn run_pose(args: &PoseArgs) -> ExitCode {
    let file = args.file.display();
    let mut request = PoseRequest {
        clip: args.clip.clone(),
        times: args.times.clone(),
        rest: args.rest,
        crossfade: args.crossfade.as_ref().map(|spec| CrossfadeRequest {
            spec: spec.clone(),
            at: args.at,
            easing: match args.easing {
                EasingArg::Linear => Easing::Linear,
                EasingArg::Smoothstep => Easing::SmoothStep,
            },
            outgoing: match args.outgoing {
                OutgoingArg::Freeze => Outgoing::Freeze,
                OutgoingArg::Keep => Outgoing::KeepPlaying,
                OutgoingArg::Sync => Outgoing::SyncTime,
            },
        }),
        layers: args
            .layers
            .iter()
            .map(|spec| LayerRequest { spec: spec.clone(), falloff: args.layer_falloff, additive: args.layer_additive })
            .collect(),
        skinning: match args.skinning {
            SkinningArg::Rigid => SkinningMethod::Rigid,
            SkinningArg::Lbs => SkinningMethod::Linear,
            SkinningArg::Dqs => SkinningMethod::DualQuaternion,
            SkinningArg::Sjb => SkinningMethod::SphericalJointBlend,
            SkinningArg::Sjbbe => SkinningMethod::SphericalJointBlendByExample,
        },
        examples: None,
        rotations: args.rotations.clone(),
    };
    if let Some(path) = &args.examples {
        match std::fs::read_to_string(path) {
            Ok(text) => request.examples = Some((path.display().to_string(), text)),
            Err(e) => {
                eprintln!("kloub: {}: {e}", path.display());
                return ExitCode::FAILURE;
            }
        }
    }
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
    write_stdout(&file.to_string(), |out| {
        serde_json::to_writer(&mut *out, &report.doc).map_err(std::io::Error::from)?;
        writeln!(out)
    })
}

fn run_inspect(args: &InspectArgs) -> ExitCode {
    let file = args.file.display().to_string();
    let doc = match inspect::inspect_file(&args.file) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("kloub: {file}: {e}");
            return ExitCode::FAILURE;
        }
    };
    write_stdout(&file, |out| {
        if args.json {
            serde_json::to_writer_pretty(&mut *out, &doc).map_err(std::io::Error::from)?;
            writeln!(out)
        } else {
            out.write_all(inspect::to_text(&doc).as_bytes())
        }
    })
}

/// Writes to stdout through `write`; a closed pipe (`kloub ... | head`) is not an error.
fn write_stdout(
    file: &str,
    write: impl FnOnce(&mut std::io::BufWriter<std::io::StdoutLock<'static>>) -> std::io::Result<()>,
) -> ExitCode {
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    match write(&mut out).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away: nothing left to report.
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
        let cli = Cli::try_parse_from(["kloub", "pose", "a.glb", "--clip", "Walk", "--time", "0.5", "--time", "-1"])
            .expect("valid");
        let Command::Pose(p) = cli.command else { panic!("pose expected") };
        assert_eq!(p.file, PathBuf::from("a.glb"));
        assert_eq!(p.clip.as_deref(), Some("Walk"));
        assert_eq!(p.times, vec![0.5, -1.0]);
        assert!(!p.rest);
        assert!(Cli::try_parse_from(["kloub", "pose", "a.glb", "--rest", "--clip", "0"]).is_err());
        assert!(Cli::try_parse_from(["kloub", "pose", "a.glb", "--time", "x"]).is_err());
    }

    #[test]
    fn blend_and_inspect_arguments_parse() {
        let cli = Cli::try_parse_from([
            "kloub",
            "pose",
            "a.glb",
            "--crossfade",
            "Walk:Run:0.5",
            "--at",
            "1",
            "--easing",
            "linear",
            "--outgoing",
            "sync",
            "--layer",
            "Wave:Abdomen:1",
            "--layer",
            "0:3:0.5",
            "--layer-falloff",
            "0.25",
        ])
        .expect("valid");
        let Command::Pose(p) = cli.command else { panic!("pose expected") };
        assert_eq!(p.crossfade.as_deref(), Some("Walk:Run:0.5"));
        assert_eq!((p.at, p.easing, p.outgoing), (1.0, EasingArg::Linear, OutgoingArg::Sync));
        assert_eq!(p.layers, ["Wave:Abdomen:1", "0:3:0.5"]);
        assert_eq!((p.layer_falloff, p.layer_additive), (0.25, false));
        for bad in [
            &["kloub", "pose", "a.glb", "--crossfade", "a:b:1", "--clip", "0"][..],
            &["kloub", "pose", "a.glb", "--crossfade", "a:b:1", "--rest"],
            &["kloub", "pose", "a.glb", "--at", "1"],
            &["kloub", "pose", "a.glb", "--layer-additive"],
            &["kloub", "pose", "a.glb", "--crossfade", "a:b:1", "--easing", "cubic"],
        ] {
            assert!(Cli::try_parse_from(bad).is_err(), "{bad:?}");
        }
        let cli = Cli::try_parse_from(["kloub", "inspect", "a.glb", "--json"]).expect("valid");
        let Command::Inspect(i) = cli.command else { panic!("inspect expected") };
        assert_eq!((i.file, i.json), (PathBuf::from("a.glb"), true));
    }

    #[test]
    fn serve_arguments_parse() {
        let cli = Cli::try_parse_from(["kloub", "serve", "--addr", "127.0.0.1:0", "--dist", "d", "--assets", "a"])
            .expect("valid");
        let Command::Serve(s) = cli.command else { panic!("serve expected") };
        assert_eq!(s.addr, "127.0.0.1:0".parse().expect("addr"));
        assert_eq!(s.dist, Some(PathBuf::from("d")));
        assert_eq!(s.assets, Some(PathBuf::from("a")));
        assert_eq!(s.max_connections, DEFAULT_MAX_CONNECTIONS);
        assert!(Cli::try_parse_from(["kloub", "serve", "--addr", "nope"]).is_err());
        let cli = Cli::try_parse_from(["kloub", "serve", "--max-connections", "8"]).expect("valid");
        let Command::Serve(s) = cli.command else { panic!("serve expected") };
        assert_eq!((s.max_connections, s.dist, s.assets), (8, None, None));
        assert!(Cli::try_parse_from(["kloub", "serve", "--max-connections", "0"]).is_err());
    }
}
