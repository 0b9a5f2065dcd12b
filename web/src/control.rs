//! The command channel between the page (the JS handle returned by `start`, and later the
//! `<kloub-viewer>` element) and the app.
//!
//! The page never touches the app directly: it resolves names against what the app published
//! for the shown model ([`Controls::clip_index`], [`Controls::node_index`]) — so a bad name is
//! an error at the call, synchronously — and queues a [`Command`]. The app applies queued
//! commands at the start of its next frame through the same [`crate::model::Model`] methods the
//! side panel uses, so a test driving the handle exercises what a click does.

use std::cell::RefCell;
use std::rc::Rc;

use kloub_core::animator::{Easing, Outgoing};
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::player::LoopMode;

use crate::candy::Sample;
use crate::render::SkinningPath;

/// The generation of commands that apply whatever model is shown (or none).
const ANY_MODEL: u64 = u64::MAX;

/// One request from the page, with names already resolved to indices of the shown model.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Run every clock (main, blended tracks, layers).
    Play,
    /// Stop every clock.
    Pause,
    /// Play `clip` (`None`: rest pose) the way a click in the clip list does: a crossfade with
    /// the panel's transition settings when something is already playing.
    PlayClip(Option<usize>),
    /// Crossfade the base to `clip` over `seconds` (0: cut), with the panel's easing and
    /// outgoing mode.
    CrossfadeTo {
        /// Target clip (`None`: rest pose).
        clip: Option<usize>,
        /// Duration in seconds.
        seconds: f32,
    },
    /// Move the main clock to a time in seconds (clamped to the clip).
    Seek(f32),
    /// Main clock speed; negative plays backwards.
    SetSpeed(f32),
    /// Main clock loop mode.
    SetLoop(LoopMode),
    /// Set the layer (`clip` `None` removes it): `clip` on the subtree under node `root`.
    SetLayer {
        /// Layer clip, or `None` to remove the layer.
        clip: Option<usize>,
        /// Root node of the affected subtree.
        root: u32,
        /// Layer weight.
        weight: f32,
    },
    /// A weighted blend of clips as the base (clip index, weight).
    SetBlend(Vec<(usize, f32)>),
    /// How skinned vertices follow their joints (kept across models).
    SetSkinning(SkinningMethod),
    /// Where vertices are deformed (kept across models).
    SetSkinningPath(SkinningPath),
    /// Colours skinned vertices by their deviation from another skinning method.
    SetHeatmap(bool),
    /// Shows a built-in sample.
    LoadSample(Sample),
    /// Drags `effector` (with `depth` rotating joints above it) towards `target` by inverse
    /// kinematics: replaces that effector's goal or adds one; `None` effector removes every
    /// goal. No target: where the effector is now.
    SetIk {
        /// The end effector node.
        effector: Option<u32>,
        /// Rotating joints above it.
        depth: usize,
        /// World-space target.
        target: Option<[f32; 3]>,
    },
    /// Sets the solver of `effector`'s goal and its options (absent: unchanged; `pole` absent
    /// removes the pole).
    SetIkSolver {
        /// The goal's end effector node.
        effector: u32,
        /// The solver.
        solver: kloub_core::job::ik::IkSolver,
        /// Two-bone: the middle joint bends towards this world point.
        pole: Option<[f32; 3]>,
        /// Two-bone: soft reach, a fraction of the chain's length in [0, 0.5].
        softness: Option<f32>,
        /// CCD: the pattern move after each sweep.
        accelerate: Option<bool>,
        /// Most iterations per frame (1 to 128).
        iterations: Option<u32>,
    },
    /// Makes goal `goal` drive `effector` with `depth` joints instead (its target stays).
    ReplaceIk {
        /// Index of the goal.
        goal: usize,
        /// The new end effector.
        effector: u32,
        /// Rotating joints above it.
        depth: usize,
    },
    /// Removes goal `goal`.
    RemoveIk(usize),
    /// Shows this many characters in a grid (1 ..= [`crate::model::MAX_COPIES`]), each
    /// [`crate::model::COPY_TIME_STEP`] seconds later than the previous.
    SetCopies(usize),
    /// Shows or hides the side panel and the menus (the element's `controls` attribute).
    SetPanels(bool),
    /// The crossfade duration a clip change uses, in seconds (0: cut).
    SetTransitionDuration(f32),
    /// How a clip change crossfades: its easing and what the outgoing clip does (`None`: unchanged).
    SetTransition {
        /// The progress curve.
        easing: Option<Easing>,
        /// The outgoing side.
        outgoing: Option<Outgoing>,
    },
    /// Fetches and shows the model at a URL.
    LoadUrl(String),
    /// The Samples menu's library (replaces the previous list).
    SetSamples(Vec<crate::samples::SampleEntry>),
    /// Places the camera: yaw and pitch (radians), distance, then the target point.
    SetCamera([f32; 6]),
    /// Bounds the camera and what the user may do to it, and sets the vertical field of view
    /// (radians; `None`: 45°). Kept across models.
    SetCameraLimits { limits: crate::render::camera::CameraLimits, fov: Option<f32> },
    /// Shows or hides the ground grid (kept across models).
    SetGrid(bool),
    /// Holds morph target `target` of node `node` at `weight` (`None`: the clip drives it).
    SetMorph {
        /// The mesh node.
        node: u32,
        /// Target index in the node's mesh.
        target: usize,
        /// Held weight, or `None` to animate.
        weight: Option<f32>,
    },
    /// Lighting preset (kept across models).
    SetLighting(crate::render::uniforms::Lighting),
    /// Background (kept across models).
    SetBackground(crate::render::uniforms::Background),
    /// Exposure, a factor on the shaded colour before tone mapping (kept across models).
    SetExposure(f32),
    /// Tone mapping (kept across models).
    SetToneMapping(crate::render::uniforms::ToneMapping),
    /// The environment lighting the meshes, with the image when it is one (kept across models).
    SetEnvironment(
        crate::render::uniforms::EnvironmentChoice,
        Option<std::sync::Arc<crate::render::environment::HdrImage>>,
    ),
    /// Forgets an environment photograph still being fetched (the page fetches an image
    /// instead); the light stays as it is.
    DropPendingEnvironment,
    /// The environment's turn about +Y, radians (kept across models).
    SetEnvironmentRotation(f32),
    /// The ground shadow's intensity and softness, 0 to 1 each (kept across models).
    SetShadow(f32, f32),
    /// The glTF-Validator's report on the shown model (the element ran it).
    #[cfg(feature = "full")]
    SetValidation(crate::validation::Validation),
    /// Turns the character into a ragdoll from the pose on screen.
    StartRagdoll,
    /// Ends the ragdoll at once (back to the animation).
    StopRagdoll,
    /// Hands the ragdoll back to the animation over this many seconds.
    RagdollToAnimation(f32),
    /// Ragdoll gravity (m/s² for a person-sized skeleton) and damping.
    SetRagdollOptions {
        /// Gravity.
        gravity: f32,
        /// Velocity damping per second.
        damping: f32,
    },
    /// The ragdoll's obstacles (replacing the list; a running ragdoll takes them at once).
    #[cfg(feature = "full")]
    SetObstacles(Vec<kloub_core::ragdoll::Obstacle>),
    /// Throws a ball from a point (model space) at a velocity (model units per second).
    #[cfg(feature = "full")]
    ThrowBall {
        /// Where it starts.
        from: [f32; 3],
        /// Its velocity.
        velocity: [f32; 3],
    },
    /// Powered ragdoll strength, 0 (limp) to 1 (follows the clip).
    SetRagdollStrength(f32),
    /// Saves the view as a PNG (a download in the browser).
    Screenshot,
    /// Which overlays are drawn (kept across models).
    SetOverlays(crate::stage::Overlays),
    /// Selects a joint (its axes and channel plot); `None` clears.
    SelectJoint(Option<u32>),
    /// Holds node `node`'s local rotation at `rotation` (a unit quaternion x, y, z, w) over the
    /// animation; `None` lets the animation drive it again.
    SetJointRotation {
        /// The node.
        node: u32,
        /// The rotation held.
        rotation: Option<[f32; 4]>,
    },
    /// Lets the animation drive every joint again (drops every held rotation).
    ResetPose,
    /// Sets σ (radians of arc) of a joint's example poses (SJB by example).
    SetExampleSigma {
        /// The joint's node.
        node: u32,
        /// σ.
        sigma: f32,
    },
    /// Enters or leaves pose mode ("Animate | Pose").
    #[cfg(feature = "full")]
    SetPoseMode(bool),
    /// Whether posing keeps joints within their IK limits.
    #[cfg(feature = "full")]
    SetPoseWithinLimits(bool),
    /// Records joint node `n`'s rotation as a new example pose and opens the sculpt on it.
    #[cfg(feature = "full")]
    AddExamplePose(u32),
    /// The sculpt's brush, radius (fraction of the model's size) and strength (0..1).
    #[cfg(feature = "full")]
    SetBrush {
        /// The brush.
        brush: kloub_core::sculpt::Brush,
        /// Its radius.
        radius: f32,
        /// Its strength.
        strength: f32,
    },
    /// Ends the sculpt: its shape becomes an example pose.
    #[cfg(feature = "full")]
    FinishSculpt,
    /// Drops the sculpt.
    #[cfg(feature = "full")]
    CancelSculpt,
    /// Deletes example pose `i` (in the sidecar's order).
    #[cfg(feature = "full")]
    DeleteExample(usize),
    /// Shows model `i` of the files dropped together (the side panel's model list).
    ShowModel(usize),
    /// Shows the "drop to open" hint (the page handles drag-and-drop itself).
    SetDropHint(bool),
    /// Poses the candy-wrapper sample by its sliders: twist and bend in degrees.
    SetCandyPose {
        /// Twist about the bone axis.
        twist: f32,
        /// Bend about Z.
        bend: f32,
    },
}

/// How every newly shown model starts: the element's `autoplay`, `animation-name`, `speed`,
/// `loop`, `layer-clip` and `layer-root` attributes. Names that the model lacks are ignored
/// (the first clip plays; no layer) with a warning in the log.
#[derive(Clone, Debug, PartialEq)]
pub struct Prefs {
    /// Start playing (else paused at the clip's start).
    pub autoplay: bool,
    /// Clip to show first (default: the model's first clip).
    pub clip: Option<String>,
    /// Speed of the base clips.
    pub speed: f32,
    /// Loop mode of the base clips.
    pub loop_mode: LoopMode,
    /// Layer: clip name, root joint name, weight.
    pub layer: Option<(String, String, f32)>,
}

impl Default for Prefs {
    fn default() -> Self {
        Self { autoplay: true, clip: None, speed: 1.0, loop_mode: LoopMode::Repeat, layer: None }
    }
}

/// What the app published about the shown model, and the queue.
#[derive(Default)]
struct Shared {
    queue: Vec<(u64, Command)>,
    /// Bumped on every model change; commands stamped with an older one are dropped.
    generation: u64,
    clips: Vec<String>,
    nodes: Vec<Option<String>>,
    repaint: Option<Wake>,
    compute: bool,
    prefs: Prefs,
    morphs: Vec<Vec<String>>,
    /// The shown model's local rotations this frame, by node.
    rotations: Vec<[f32; 4]>,
}

/// Asks a viewer for a frame: its egui context's repaint (the full app), or the element's
/// `kloub:wake` (the widget build). Single-threaded, like the page.
#[derive(Clone)]
pub struct Wake(Rc<dyn Fn()>);

impl Wake {
    /// A waker calling `f`.
    pub fn new(f: impl Fn() + 'static) -> Self {
        Self(Rc::new(f))
    }

    /// Wakes an egui context.
    #[cfg(feature = "full")]
    pub fn egui(ctx: &egui::Context) -> Self {
        let ctx = ctx.clone();
        Self::new(move || ctx.request_repaint())
    }

    /// Whether `other` is this very waker (a clone of it).
    pub fn same(&self, other: &Wake) -> bool {
        Rc::ptr_eq(&self.0, &other.0)
    }

    /// Asks for a frame.
    pub fn wake(&self) {
        (self.0)();
    }
}

impl std::fmt::Debug for Wake {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Wake")
    }
}

/// A cheap, clonable handle on the command channel (single-threaded, like the page).
#[derive(Clone, Default)]
pub struct Controls(Rc<RefCell<Shared>>);

impl std::fmt::Debug for Controls {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shared = self.0.borrow();
        f.debug_struct("Controls")
            .field("queued", &shared.queue.len())
            .field("generation", &shared.generation)
            .field("clips", &shared.clips.len())
            .finish()
    }
}

impl Controls {
    /// Queues `command` for the model shown now, and wakes the app.
    pub fn send(&self, command: Command) {
        let repaint = {
            let mut shared = self.0.borrow_mut();
            let generation = shared.generation;
            shared.queue.push((generation, command));
            shared.repaint.clone()
        };
        if let Some(wake) = repaint {
            wake.wake();
        }
    }

    /// What wakes the app (to hand to an async reader).
    pub(crate) fn waker(&self) -> Option<Wake> {
        self.0.borrow().repaint.clone()
    }

    /// Wakes the app (something arrived outside the queue, e.g. files).
    pub fn wake(&self) {
        let repaint = self.0.borrow().repaint.clone();
        if let Some(wake) = repaint {
            wake.wake();
        }
    }

    /// Index of the clip named `name` in the shown model.
    ///
    /// # Errors
    /// A message listing the available clips.
    pub fn clip_index(&self, name: &str) -> Result<usize, String> {
        let shared = self.0.borrow();
        shared.clips.iter().position(|c| c == name).ok_or_else(|| {
            if shared.clips.is_empty() {
                format!("no clip named {name:?}: the shown model has no clips")
            } else {
                format!("no clip named {name:?}; clips: {}", shared.clips.join(", "))
            }
        })
    }

    /// Queues a command that does not depend on the shown model (skinning settings, samples):
    /// it survives a model change.
    pub fn send_global(&self, command: Command) {
        let repaint = {
            let mut shared = self.0.borrow_mut();
            shared.queue.push((ANY_MODEL, command));
            shared.repaint.clone()
        };
        if let Some(wake) = repaint {
            wake.wake();
        }
    }

    /// Index of the first node named `name` in the shown model.
    ///
    /// # Errors
    /// A message when no node has that name.
    pub fn node_index(&self, name: &str) -> Result<u32, String> {
        let shared = self.0.borrow();
        let named = shared.nodes.iter().position(|n| n.as_deref() == Some(name));
        // An unnamed node goes by "node N", as the state mirrors and the panel write it.
        let unnamed = || {
            let i: usize = name.strip_prefix("node ")?.parse().ok()?;
            shared.nodes.get(i).is_some_and(|n| n.as_deref().is_none_or(str::is_empty)).then_some(i)
        };
        named
            .or_else(unnamed)
            .and_then(|i| u32::try_from(i).ok())
            .ok_or_else(|| format!("no joint or node named {name:?} in the shown model"))
    }

    /// The node named `name` that carries morph targets: names repeat in many files (a joint
    /// and its mesh node both called `Head`), so a node with targets wins over earlier ones
    /// without; else the first node of that name.
    pub fn morph_node_index(&self, name: &str) -> Result<u32, String> {
        let with_targets = {
            let shared = self.0.borrow();
            (shared.nodes.iter().zip(shared.morphs.iter().chain(std::iter::repeat(&Vec::new()))))
                .position(|(n, targets)| n.as_deref() == Some(name) && !targets.is_empty())
                .and_then(|i| u32::try_from(i).ok())
        };
        with_targets.map_or_else(|| self.node_index(name), Ok)
    }

    /// Whether the renderer has the compute skinning path (WebGPU, native; not WebGL2).
    pub fn supports_compute(&self) -> bool {
        self.0.borrow().compute
    }

    /// The app's side: announces whether the compute skinning path exists.
    pub(crate) fn set_supports_compute(&self, supported: bool) {
        self.0.borrow_mut().compute = supported;
    }

    /// Sets how the next models start (see [`Prefs`]); the shown model is not changed.
    pub fn set_prefs(&self, prefs: Prefs) {
        self.0.borrow_mut().prefs = prefs;
    }

    /// How the next models start.
    pub fn prefs(&self) -> Prefs {
        self.0.borrow().prefs.clone()
    }

    /// The local rotation (x, y, z, w) of the joint or node named `name` in the shown model's
    /// last drawn pose.
    ///
    /// # Errors
    /// An unknown name, or no pose drawn yet.
    pub fn joint_rotation(&self, name: &str) -> Result<[f32; 4], String> {
        let node = self.node_index(name)?;
        self.0.borrow().rotations.get(node as usize).copied().ok_or_else(|| format!("{name:?} has no pose yet"))
    }

    /// The app's side: the shown model's local rotations of this frame (the vector is reused).
    pub(crate) fn publish_rotations(&self, rotations: impl Iterator<Item = [f32; 4]>) {
        let mut shared = self.0.borrow_mut();
        shared.rotations.clear();
        shared.rotations.extend(rotations);
    }

    /// Names of the shown model's clips.
    pub fn clip_names(&self) -> Vec<String> {
        self.0.borrow().clips.clone()
    }

    /// The app's side: publishes a new model's names and drops commands meant for the old one.
    /// `morphs[n]` names node `n`'s morph targets (empty without morphs).
    pub(crate) fn publish(&self, clips: Vec<String>, nodes: Vec<Option<String>>, morphs: Vec<Vec<String>>) {
        let mut shared = self.0.borrow_mut();
        shared.generation += 1;
        shared.queue.retain(|(g, _)| *g == ANY_MODEL);
        shared.clips = clips;
        shared.nodes = nodes;
        shared.morphs = morphs;
    }

    /// Index of the morph target named `name` on node `node` of the shown model.
    ///
    /// # Errors
    /// A message listing the node's targets.
    pub fn morph_target_index(&self, node: u32, name: &str) -> Result<usize, String> {
        let shared = self.0.borrow();
        let names = shared.morphs.get(node as usize).map_or(&[][..], Vec::as_slice);
        names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| format!("no morph target named {name:?} on that node; targets: {}", names.join(", ")))
    }

    /// The app's side: what to wake when a command arrives.
    pub(crate) fn set_repaint(&self, wake: Wake) {
        self.0.borrow_mut().repaint = Some(wake);
    }

    /// The app's side: takes the commands queued for the current model (and the global ones),
    /// in order.
    pub(crate) fn take(&self) -> Vec<Command> {
        let mut shared = self.0.borrow_mut();
        let generation = shared.generation;
        std::mem::take(&mut shared.queue)
            .into_iter()
            .filter(|(g, _)| *g == generation || *g == ANY_MODEL)
            .map(|(_, c)| c)
            .collect()
    }
}

/// Parses a loop mode name: `once`, `repeat` or `pingpong` (also `ping-pong`).
///
/// # Errors
/// A message naming the accepted values.
pub fn parse_loop_mode(name: &str) -> Result<LoopMode, String> {
    match name {
        "once" => Ok(LoopMode::Once),
        "repeat" => Ok(LoopMode::Repeat),
        "pingpong" | "ping-pong" => Ok(LoopMode::PingPong),
        _ => Err(format!("loop mode {name:?}: expected \"once\", \"repeat\" or \"pingpong\"")),
    }
}

/// A crossfade easing by its page name: `"smoothstep"` or `"linear"` (`kloub pose --easing`).
pub fn parse_easing(name: &str) -> Result<Easing, String> {
    match name {
        "smoothstep" => Ok(Easing::SmoothStep),
        "linear" => Ok(Easing::Linear),
        _ => Err(format!("easing {name:?}: expected \"smoothstep\" or \"linear\"")),
    }
}

/// The page name of an easing (inverse of [`parse_easing`]).
pub fn easing_name(easing: Easing) -> &'static str {
    match easing {
        Easing::SmoothStep => "smoothstep",
        Easing::Linear => "linear",
    }
}

/// What the outgoing clip does during a crossfade, by its page name: `"freeze"`, `"keep"` (keeps
/// playing) or `"sync"` (keeps playing, the new clip starts in step; `kloub pose --outgoing`).
pub fn parse_outgoing(name: &str) -> Result<Outgoing, String> {
    match name {
        "freeze" => Ok(Outgoing::Freeze),
        "keep" => Ok(Outgoing::KeepPlaying),
        "sync" => Ok(Outgoing::SyncTime),
        _ => Err(format!("outgoing {name:?}: expected \"freeze\", \"keep\" or \"sync\"")),
    }
}

/// The page name of an outgoing mode (inverse of [`parse_outgoing`]).
pub fn outgoing_name(outgoing: Outgoing) -> &'static str {
    match outgoing {
        Outgoing::Freeze => "freeze",
        Outgoing::KeepPlaying => "keep",
        Outgoing::SyncTime => "sync",
    }
}

/// The page name of a loop mode (inverse of [`parse_loop_mode`]).
pub fn loop_mode_name(mode: LoopMode) -> &'static str {
    match mode {
        LoopMode::Once => "once",
        LoopMode::Repeat => "repeat",
        LoopMode::PingPong => "pingpong",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_morph_node_wins_over_an_earlier_node_of_the_same_name() {
        let c = Controls::default();
        let nodes = vec![Some("Head".into()), Some("Head".into()), Some("Hips".into())];
        c.publish(vec![], nodes, vec![vec![], vec!["Angry".into()], vec![]]);
        assert_eq!(c.morph_node_index("Head"), Ok(1));
        assert_eq!(c.node_index("Head"), Ok(0));
        assert_eq!(c.morph_node_index("Hips"), Ok(2), "no node with targets: the first of that name");
        c.publish(vec![], vec![None, Some("Hips".into()), Some(String::new())], vec![]);
        assert_eq!(c.node_index("node 0"), Ok(0), "unnamed nodes go by \"node N\"");
        assert_eq!(c.node_index("node 2"), Ok(2));
        assert!(c.node_index("node 1").is_err(), "a named node goes by its name only");
        assert!(c.node_index("node 9").is_err());
        assert!(c.morph_node_index("Tail").is_err());
    }

    #[test]
    fn transition_names_round_trip_and_unknown_ones_are_refused() {
        for easing in [Easing::SmoothStep, Easing::Linear] {
            assert_eq!(parse_easing(easing_name(easing)), Ok(easing));
        }
        for outgoing in [Outgoing::Freeze, Outgoing::KeepPlaying, Outgoing::SyncTime] {
            assert_eq!(parse_outgoing(outgoing_name(outgoing)), Ok(outgoing));
        }
        assert!(parse_easing("cubic").is_err_and(|e| e.contains("smoothstep")));
        assert!(parse_outgoing("fade").is_err_and(|e| e.contains("freeze")));
    }

    #[test]
    fn names_resolve_against_the_published_model() {
        let c = Controls::default();
        assert!(c.clip_index("Walk").expect_err("no model yet").contains("no clips"));
        c.publish(vec!["Survey".into(), "Walk".into()], vec![None, Some("Hips".into())], vec![]);
        assert_eq!(c.clip_index("Walk"), Ok(1));
        assert!(c.clip_index("Run").expect_err("no such clip").contains("Survey, Walk"));
        assert_eq!(c.node_index("Hips"), Ok(1));
        assert!(c.node_index("Head").is_err());
    }

    #[test]
    fn commands_for_an_older_model_are_dropped() {
        let c = Controls::default();
        c.publish(vec!["A".into()], vec![], vec![]);
        c.send(Command::Pause);
        c.send(Command::Seek(0.5));
        assert_eq!(c.take(), vec![Command::Pause, Command::Seek(0.5)]);
        assert!(c.take().is_empty());
        c.send(Command::Play);
        c.publish(vec!["B".into()], vec![], vec![]);
        assert!(c.take().is_empty(), "a new model drops queued commands");
    }

    #[test]
    fn loop_modes_round_trip() {
        for mode in [LoopMode::Once, LoopMode::Repeat, LoopMode::PingPong] {
            assert_eq!(parse_loop_mode(loop_mode_name(mode)), Ok(mode));
        }
        assert!(parse_loop_mode("forever").is_err());
    }
}
