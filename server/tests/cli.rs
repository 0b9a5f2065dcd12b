//! The `kloub` binary as users run it: exit codes, stdout/stderr, `serve` start-up and shutdown.

mod common;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn kloub() -> Command {
    Command::new(env!("CARGO_BIN_EXE_kloub"))
}

/// `tests/assets` in the repository, overridable with `KLOUB_SHARED_ASSETS`.
fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"))
}

fn rigged_simple() -> PathBuf {
    shared_assets().join("khronos/RiggedSimple/glTF-Binary/RiggedSimple.glb")
}

#[test]
fn pose_prints_the_contract_json() {
    let out = kloub()
        .arg("pose")
        .arg(rigged_simple())
        .args(["--time", "0", "--time", "1.04", "--clip", "0"])
        .output()
        .expect("runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(doc["asset"], "RiggedSimple.glb");
    assert_eq!(doc["clip"]["index"], 0);
    assert_eq!(doc["frames"].as_array().expect("frames").len(), 2);
    // serde_json's default parser may be 1 ulp off in f64; narrowing gives the f32 back.
    let time = doc["frames"][1]["time"].as_f64().expect("a number");
    assert_eq!(time as f32, 1.04f32);
    assert!((time - f64::from(1.04f32)).abs() <= 2.0 * f64::EPSILON, "full f32 precision");
}

#[test]
fn pose_errors_name_file_and_pointer_and_exit_1() {
    let file = rigged_simple();
    let out = kloub().arg("pose").arg(&file).args(["--clip", "Nope"]).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    let want = format!("kloub: {}: /animations: no clip \"Nope\"; available: 0", file.display());
    assert!(err.starts_with(&want), "{err}");

    let out = kloub().args(["pose", "/nonexistent/x.glb"]).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("kloub: /nonexistent/x.glb: cannot read: "), "{err}");

    let out = kloub().args(["pose", "x.glb", "--rest", "--clip", "0"]).output().expect("runs");
    assert_eq!(out.status.code(), Some(2), "usage error");
}

#[test]
fn pose_refuses_external_files_leaving_the_folder() {
    let base = common::temp_dir("cli-escape");
    std::fs::create_dir_all(base.join("model")).expect("mkdir");
    std::fs::write(base.join("outside.bin"), [0u8; 12]).expect("write");
    #[cfg(unix)]
    std::os::unix::fs::symlink(base.join("outside.bin"), base.join("model/link.bin")).expect("symlink");
    let mut uris = vec!["../outside.bin", "%2e%2e/outside.bin"];
    if cfg!(unix) {
        uris.push("link.bin");
    }
    for uri in uris {
        let gltf = format!(r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":12}}]}}"#);
        let file = base.join("model/escape.gltf");
        std::fs::write(&file, gltf).expect("write");
        let out = kloub().arg("pose").arg(&file).output().expect("runs");
        assert_eq!(out.status.code(), Some(1), "{uri}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with(&format!("kloub: {}: /buffers/0", file.display())), "{err}");
        assert!(err.contains("outside") || err.contains("refused"), "{uri}: {err}");
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[cfg(unix)]
#[test]
fn serve_announces_its_address_reads_env_and_stops_on_sigint() {
    let base = common::temp_dir("cli-serve");
    std::fs::create_dir_all(base.join("dist")).expect("mkdir");
    std::fs::create_dir_all(base.join("lib")).expect("mkdir");
    std::fs::write(base.join("dist/index.html"), "<p>hi</p>").expect("write");
    std::fs::write(base.join("lib/Fox.glb"), "fox").expect("write");
    let mut child = kloub()
        .args(["serve", "--addr", "127.0.0.1:0", "--dist"])
        .arg(base.join("dist"))
        .env("KLOUB_ASSETS", base.join("lib"))
        .env("KLOUB_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("starts");
    let stdout = child.stdout.take().expect("piped stdout");
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).expect("a first line");
    let addr = line
        .trim()
        .strip_prefix("kloub serve: listening on http://")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"));
    let addr = addr.parse().expect("a socket address");

    let reply = common::request(addr, "GET", "/models/default.glb", &[]);
    assert_eq!((reply.status, reply.body.as_slice()), (200, b"fox".as_slice()));
    assert_eq!(common::request(addr, "GET", "/", &[]).text(), "<p>hi</p>");

    let killed = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
    assert!(killed.expect("kill runs").success());
    let status = child.wait().expect("exits");
    assert!(status.success(), "graceful shutdown exits 0, got {status}");
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Runs `kloub ARGS`, expecting success; returns stdout.
fn kloub_ok(args: &[&str]) -> Vec<u8> {
    let out = kloub().args(args).output().expect("runs");
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

fn pose_json(file: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let file = file.to_str().expect("a UTF-8 path");
    let mut all = vec!["pose", file];
    all.extend_from_slice(args);
    serde_json::from_slice(&kloub_ok(&all)).expect("JSON on stdout")
}

/// World matrices of every node of frame `f`.
fn worlds(doc: &serde_json::Value, f: usize) -> Vec<Vec<f64>> {
    doc["frames"][f]["nodes"]
        .as_array()
        .expect("nodes")
        .iter()
        .map(|n| n["world"].as_array().expect("world").iter().map(|x| x.as_f64().expect("a number")).collect())
        .collect()
}

fn max_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn fox() -> PathBuf {
    shared_assets().join("khronos/Fox/glTF-Binary/Fox.glb")
}

fn robot() -> PathBuf {
    shared_assets().join("threejs/RobotExpressive/RobotExpressive.glb")
}

#[test]
fn pose_crossfade_starts_from_the_source_and_ends_on_the_target() {
    // Walk plays from 0; at 0.5 s it fades to Run over 0.375 s (frozen source, linear).
    // Binary fractions, so that `time - at` is exact in f32.
    let args = ["--crossfade", "Walk:Run:0.375", "--at", "0.5", "--easing", "linear"];
    let times = ["0.25", "0.5", "0.59375", "0.6875", "0.78125", "0.875", "1.25"];
    let mut all = args.to_vec();
    for t in &times {
        all.extend(["--time", t]);
    }
    let doc = pose_json(&fox(), &all);
    assert_eq!(doc["clip"]["name"], "Walk");
    let fade = &doc["crossfade"];
    assert_eq!((&fade["from"]["name"], &fade["to"]["name"]), (&"Walk".into(), &"Run".into()));
    assert_eq!((fade["duration"].as_f64(), fade["at"].as_f64()), (Some(0.375), Some(0.5)));
    assert_eq!((&fade["easing"], &fade["outgoing"]), (&"linear".into(), &"freeze".into()));
    assert!(doc.get("layers").is_none(), "no layers: no key");

    let walk = pose_json(&fox(), &["--clip", "Walk", "--time", "0.25", "--time", "0.5"]);
    let run = pose_json(&fox(), &["--clip", "Run", "--time", "0.375", "--time", "0.75"]);
    // Before and at the start: Walk exactly.
    assert_eq!(worlds(&doc, 0), worlds(&walk, 0));
    assert_eq!(worlds(&doc, 1), worlds(&walk, 1));
    // At the end and after: Run, started at 0.5 s.
    assert_eq!(worlds(&doc, 5), worlds(&run, 0));
    assert_eq!(worlds(&doc, 6), worlds(&run, 1));
    // In between: neither, and closer to Run as time goes on (relative to the snapshot).
    let mut previous = f64::INFINITY;
    for f in 2..5 {
        let to_walk = max_difference(&worlds(&doc, f), &worlds(&walk, 1));
        let to_run = max_difference(&worlds(&doc, f), &worlds(&run, 0));
        assert!(to_walk > 1e-3 && to_run > 1e-3, "frame {f} is a blend");
        assert!(to_run < previous, "frame {f} moves towards Run");
        previous = to_run;
    }
}

#[test]
fn pose_layer_moves_only_the_subtree_under_its_root() {
    let inspect: serde_json::Value =
        serde_json::from_slice(&kloub_ok(&["inspect", robot().to_str().expect("UTF-8"), "--json"])).expect("JSON");
    let nodes = inspect["nodes"].as_array().expect("nodes");
    let parent = |n: usize| nodes[n]["parent"].as_u64().map(|p| p as usize);
    let root = nodes.iter().position(|n| n["name"] == "Abdomen").expect("the robot has an Abdomen joint");
    let under_root = |mut n: usize| loop {
        if n == root {
            break true;
        }
        match parent(n) {
            Some(p) => n = p,
            None => break false,
        }
    };

    let base = pose_json(&robot(), &["--clip", "Walking", "--time", "0.4"]);
    let layered = pose_json(&robot(), &["--clip", "Walking", "--time", "0.4", "--layer", "Wave:Abdomen:1"]);
    assert_eq!(layered["layers"][0]["root"]["index"], root);
    assert_eq!(layered["layers"][0]["clip"]["name"], "Wave");
    let (base, layered) = (worlds(&base, 0), worlds(&layered, 0));
    let mut moved = 0;
    for (n, (b, l)) in base.iter().zip(&layered).enumerate() {
        if under_root(n) {
            moved += usize::from(b != l);
        } else {
            assert_eq!(b, l, "node {n} is outside the layer's subtree");
        }
    }
    assert!(moved > 10, "the upper body waves ({moved} nodes moved)");

    // By node index and with a falloff: the same subtree, moved less far down the arms.
    let root_index = root.to_string();
    let spec = format!("12:{root_index}:1");
    let falloff =
        pose_json(&robot(), &["--clip", "Walking", "--time", "0.4", "--layer", &spec, "--layer-falloff", "0.5"]);
    assert_eq!(falloff["layers"][0]["falloff"], 0.5);
    let falloff = worlds(&falloff, 0);
    for (n, (b, f)) in base.iter().zip(&falloff).enumerate() {
        if !under_root(n) {
            assert_eq!(b, f, "node {n}");
        }
    }
    assert_ne!(falloff, layered);
}

#[test]
fn pose_blending_errors_are_clear() {
    let fox = fox();
    let file = fox.to_str().expect("UTF-8");
    for (args, message) in [
        (
            vec!["--crossfade", "Walk:Trot:1"],
            "/animations: --crossfade \"Walk:Trot:1\": no such pair of clips; available: 0 \"Survey\"",
        ),
        (vec!["--crossfade", "Walk:Run"], "--crossfade \"Walk:Run\": \"Run\" is not a number"),
        (vec!["--layer", "Walk:nose:1"], "--layer \"Walk:nose:1\": no clip and node of those names"),
        (vec!["--layer", "Walk:b_Head_05:-1"], "must be a finite number ≥ 0"),
        (
            vec!["--layer", "Walk:b_Head_05:1", "--time", "-1"],
            "time -1: with --crossfade or --layer, times count from the start",
        ),
    ] {
        let mut all = vec!["pose", file];
        all.extend(&args);
        let out = kloub().args(&all).output().expect("runs");
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with(&format!("kloub: {file}: ")) && err.contains(message), "{args:?}: {err}");
    }
    let help = String::from_utf8(kloub_ok(&["pose", "--help"])).expect("UTF-8");
    for needle in ["--crossfade <FROM:TO:DURATION>", "--layer <CLIP:ROOT_JOINT:WEIGHT>", "\"layers\""] {
        assert!(help.contains(needle), "{needle}");
    }
}

#[test]
fn inspect_describes_skins_clips_morph_targets_and_warnings() {
    let file = robot();
    let path = file.to_str().expect("UTF-8");
    let doc: serde_json::Value = serde_json::from_slice(&kloub_ok(&["inspect", path, "--json"])).expect("JSON");
    assert_eq!(doc["asset"], "RobotExpressive.glb");
    assert_eq!(doc["nodes"].as_array().expect("nodes").len(), 74);
    let skins = doc["skins"].as_array().expect("skins");
    assert_eq!(skins.len(), 2);
    let joints = skins[0]["joints"].as_array().expect("joints");
    assert_eq!(joints.len(), 43);
    let hips = joints.iter().find(|j| j["name"] == "Abdomen").expect("Abdomen");
    let parent = &joints[hips["parent_joint"].as_u64().expect("a parent joint") as usize];
    assert_eq!(parent["name"], "Hips");
    assert_eq!(hips["depth"], parent["depth"].as_u64().expect("depth") + 1);
    let clips = doc["clips"].as_array().expect("clips");
    assert_eq!(clips.len(), 14);
    let wave = clips.iter().find(|c| c["name"] == "Wave").expect("Wave");
    let channels = wave["channels"].as_array().expect("channels");
    assert_eq!(wave["channel_count"], channels.len());
    assert!(channels.iter().all(|c| c["interpolation"] == "LINEAR"));
    assert!(channels.iter().any(|c| c["path"] == "weights"));
    let head = doc["meshes"].as_array().expect("meshes").iter().find(|m| m["name"] == "Head").expect("a Head mesh");
    assert_eq!(head["target_names"], serde_json::json!(["Angry", "Surprised", "Sad"]));
    let warnings = doc["warnings"].as_array().expect("warnings");
    assert!(
        warnings.iter().any(|w| w["pointer"].as_str().is_some_and(|p| p.ends_with("WEIGHTS_0"))),
        "the unnormalized weights are reported"
    );

    let text = String::from_utf8(kloub_ok(&["inspect", path])).expect("UTF-8");
    assert!(text.starts_with("RobotExpressive.glb: 74 nodes, 1 scenes, 2 skins, 14 clips"), "{text}");
    assert!(text.contains("3 morph targets (Angry, Surprised, Sad)"), "{text}");
    assert!(text.contains("\"Wave\": 1.833 s"), "{text}");
    assert!(text.contains("WEIGHTS_0: skin weights"), "{text}");

    // Images with their decoded size, and the extensions a file uses.
    assert_eq!(doc["images"], serde_json::json!([]));
    assert_eq!(
        (doc["extensions_used"].clone(), doc["extensions_required"].clone()),
        (serde_json::json!([]), serde_json::json!([]))
    );
    let multi = shared_assets().join("khronos/TextureTransformMultiTest/glTF-Binary/TextureTransformMultiTest.glb");
    let doc: serde_json::Value =
        serde_json::from_slice(&kloub_ok(&["inspect", multi.to_str().expect("UTF-8"), "--json"])).expect("JSON");
    assert_eq!(
        doc["extensions_used"],
        serde_json::json!(["KHR_texture_transform", "KHR_materials_unlit", "KHR_materials_clearcoat"])
    );
    assert_eq!(doc["extensions_required"], serde_json::json!(["KHR_texture_transform"]));
    let fox = fox();
    let doc: serde_json::Value =
        serde_json::from_slice(&kloub_ok(&["inspect", fox.to_str().expect("UTF-8"), "--json"])).expect("JSON");
    let image = &doc["images"][0];
    assert_eq!((image["width"].as_u64(), image["height"].as_u64()), (Some(1024), Some(1024)));
    assert_eq!(image["decoded_bytes"], 4 << 20);
    let text = String::from_utf8(kloub_ok(&["inspect", fox.to_str().expect("UTF-8")])).expect("UTF-8");
    assert!(text.contains("1024×1024, 4.0 MB decoded") && text.contains("extensions: used (none)"), "{text}");
    assert_eq!(doc["compressed_views"], serde_json::json!([]));
    // A meshopt-compressed copy: every compressed view with its mode, filter and sizes.
    let packed = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/optimized/Fox.gltfpack-cc.glb");
    let doc: serde_json::Value =
        serde_json::from_slice(&kloub_ok(&["inspect", packed.to_str().expect("UTF-8"), "--json"])).expect("JSON");
    let views = doc["compressed_views"].as_array().expect("compressed_views");
    assert!(views.len() >= 3, "{views:?}");
    assert!(views.iter().all(|v| v["extension"] == "EXT_meshopt_compression"), "{views:?}");
    assert!(views.iter().any(|v| v["mode"] == "TRIANGLES") && views.iter().any(|v| v["filter"] == "QUATERNION"));
    assert!(views.iter().all(|v| v["compressed_bytes"].as_u64() < v["decoded_bytes"].as_u64()), "{views:?}");
    let text = String::from_utf8(kloub_ok(&["inspect", packed.to_str().expect("UTF-8")])).expect("UTF-8");
    assert!(text.contains(&format!("compressed: {} buffer views", views.len())), "{text}");

    let out = kloub().args(["inspect", "/nonexistent/x.glb"]).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("kloub: /nonexistent/x.glb: cannot read: "));
}

/// Skinned positions of frame 0, primitive 0, as points.
fn positions(doc: &serde_json::Value) -> Vec<[f64; 3]> {
    let flat = doc["frames"][0]["primitives"][0]["positions"].as_array().expect("positions");
    flat.chunks(3).map(|c| [0, 1, 2].map(|i| c[i].as_f64().expect("a number"))).collect()
}

#[test]
fn pose_skinning_methods_share_the_skeleton_and_differ_in_the_skin() {
    let file = fox();
    let args = ["--clip", "Run", "--time", "0.3"];
    let lbs = pose_json(&file, &args);
    assert!(lbs.get("skinning").is_none(), "the default (lbs) is not announced");
    let explicit = pose_json(&file, &[&args[..], &["--skinning", "lbs"]].concat());
    assert_eq!(positions(&lbs), positions(&explicit));
    let reach = |doc: &serde_json::Value| {
        let p = positions(doc);
        p.iter()
            .zip(positions(&lbs))
            .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max)
    };
    for (name, low, high) in [("dqs", 1e-4, 10.0), ("sjb", 1e-4, 10.0), ("rigid", 1e-3, 40.0)] {
        let doc = pose_json(&file, &[&args[..], &["--skinning", name]].concat());
        assert_eq!(doc["skinning"], name);
        assert_eq!(worlds(&doc, 0), worlds(&lbs, 0), "{name}: the skeleton does not depend on skinning");
        let d = reach(&doc);
        // Fox is ~100 units long: the methods agree where one joint dominates and part where
        // influences blend.
        assert!(d > low && d < high, "{name}: largest vertex difference from lbs {d}");
    }
    let sjb = pose_json(&file, &[&args[..], &["--skinning", "sjb"]].concat());
    let fallbacks = sjb["frames"][0]["primitives"][0]["sjb_fallbacks"].as_u64().expect("sjb reports its fallbacks");
    let count = sjb["frames"][0]["primitives"][0]["count"].as_u64().expect("count");
    assert!(fallbacks < count, "{fallbacks} of {count} vertices fell back");
    assert!(lbs["frames"][0]["primitives"][0].get("sjb_fallbacks").is_none());
    let out = kloub().arg("pose").arg(&file).args(["--skinning", "vsp"]).output().expect("runs");
    assert_eq!(out.status.code(), Some(2), "an unknown method is a usage error");
}

/// `kloub ik` brings RiggedFigure's left hand from its pose at 0 s to where the clip has it at
/// 0.9 s, with every solver; the JSON contract's fields are there; bad input is an error.
#[test]
fn ik_reaches_a_target_with_every_solver() {
    let file = shared_assets().join("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb");
    let path = file.to_str().expect("a UTF-8 path");
    let later = pose_json(&file, &["--clip", "0", "--time", "0.9"]);
    let hand = later["frames"][0]["nodes"]
        .as_array()
        .expect("nodes")
        .iter()
        .find(|n| n["name"] == "arm_joint_L_3")
        .expect("the left hand")["world"]
        .as_array()
        .expect("world")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect::<Vec<f64>>();
    let target = format!("{},{},{}", hand[12], hand[13], hand[14]);
    for solver in ["ccd", "twobone", "fabrik", "dls"] {
        let args = [
            "ik",
            path,
            "--clip",
            "0",
            "--time",
            "0",
            "--effector",
            "arm_joint_L_3",
            "--depth",
            "2",
            "--target",
            &target,
            "--solver",
            solver,
            "--iterations",
            "200",
        ];
        let doc: serde_json::Value = serde_json::from_slice(&kloub_ok(&args)).expect("JSON on stdout");
        assert_eq!(doc["solver"], solver);
        assert_eq!(doc["effector"]["name"], "arm_joint_L_3");
        let error = doc["error"].as_f64().expect("error");
        assert!(error < 1e-3, "{solver}: error {error}");
        let chain = doc["chain"].as_array().expect("chain");
        assert_eq!(chain.len(), 3);
        assert_eq!(chain[0]["name"], "arm_joint_L_1");
        let reached = doc["reached"].as_array().expect("reached");
        let last = chain[2]["world"].as_array().expect("world");
        assert_eq!(reached, last, "{solver}: reached is the effector's world position");
        assert!(doc["iterations"].as_u64().expect("iterations") >= 1);
    }
    // CCD's pattern move: the default reaches this near-full-reach target in a few sweeps; seed
    // 000's plain CCD is still creeping after 32.
    let sweeps = |extra: &[&str]| {
        let mut args =
            vec!["ik", path, "--clip", "0", "--effector", "arm_joint_L_3", "--depth", "2", "--target", &target];
        args.extend_from_slice(extra);
        let doc: serde_json::Value = serde_json::from_slice(&kloub_ok(&args)).expect("JSON on stdout");
        (doc["error"].as_f64().expect("error"), doc["iterations"].as_u64().expect("iterations"))
    };
    let (error, iterations) = sweeps(&[]);
    assert!(error <= 1e-4 && iterations <= 8, "ccd: error {error} after {iterations} sweeps");
    let (plain_error, plain_iterations) = sweeps(&["--plain-ccd"]);
    assert!(plain_iterations == 32 && plain_error > 1e-4, "plain ccd: error {plain_error} after {plain_iterations}");
    // Two-bone's soft reach stops short of a target inside its band; out-of-range softness is an error.
    let (hard, _) = sweeps(&["--solver", "twobone"]);
    let (soft, _) = sweeps(&["--solver", "twobone", "--soft", "0.9"]);
    assert!(hard < 1e-4 && soft > 1e-3 && soft.is_finite(), "two-bone: hard {hard}, soft {soft}");
    let mut bad = vec!["ik", path, "--effector", "arm_joint_L_3", "--depth", "2", "--target", &target];
    bad.extend_from_slice(&["--solver", "twobone", "--soft", "1.5"]);
    let out = kloub().args(&bad).output().expect("runs");
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("softness"));
    let limited = [
        "ik",
        path,
        "--effector",
        "arm_joint_L_3",
        "--depth",
        "2",
        "--target",
        &target,
        "--humanoid-limits",
        "--solver",
        "dls",
    ];
    let doc: serde_json::Value = serde_json::from_slice(&kloub_ok(&limited)).expect("JSON on stdout");
    assert!(doc["error"].as_f64().expect("error").is_finite());
    // A sidecar that freezes the shoulder (stiffness 0): only the elbow turns.
    let dir = std::env::temp_dir().join(format!("kloub-ik-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let sidecar = dir.join("RiggedFigure.kloub.json");
    std::fs::write(&sidecar, r#"{"ik": {"stiffness": {"arm_joint_L_1": 0}}}"#).expect("write");
    let frozen = [
        "ik",
        path,
        "--effector",
        "arm_joint_L_3",
        "--depth",
        "2",
        "--target",
        &target,
        "--limits",
        sidecar.to_str().expect("UTF-8"),
    ];
    let doc: serde_json::Value = serde_json::from_slice(&kloub_ok(&frozen)).expect("JSON on stdout");
    let rest: serde_json::Value = serde_json::from_slice(&kloub_ok(&[
        "ik",
        path,
        "--effector",
        "arm_joint_L_3",
        "--depth",
        "2",
        "--target",
        &target,
        "--iterations",
        "0",
    ]))
    .expect("JSON on stdout");
    assert_eq!(doc["chain"][0]["rotation"], rest["chain"][0]["rotation"], "the shoulder with stiffness 0 moved");
    assert_ne!(doc["chain"][1]["rotation"], rest["chain"][1]["rotation"], "the elbow did not move");
    std::fs::write(&sidecar, r#"{"ik": {"limits": {"nope": "free"}}}"#).expect("write");
    let out = kloub().args(frozen).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("/ik/limits/nope"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
    for bad in [
        vec!["--effector", "nope", "--depth", "2", "--target", "0,0,0"],
        vec!["--effector", "arm_joint_L_3", "--depth", "40", "--target", "0,0,0"],
        vec!["--effector", "arm_joint_L_3", "--depth", "3", "--target", "0,0,0", "--solver", "twobone"],
        vec!["--effector", "arm_joint_L_3", "--depth", "2", "--target", "0,0,0", "--stiffness", "1,2"],
    ] {
        let out = kloub().args(["ik", path]).args(&bad).output().expect("runs");
        assert_eq!(out.status.code(), Some(1), "{bad:?} should fail: {}", String::from_utf8_lossy(&out.stdout));
        assert!(!out.stderr.is_empty());
    }
    let out = kloub()
        .args(["ik", path, "--effector", "arm_joint_L_3", "--depth", "2", "--target", "0,nan,0"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2), "a non-finite target is a usage error");
}

#[test]
fn ragdoll_prints_every_frame_falls_and_repeats_itself() {
    let file = fox();
    let path = file.to_str().expect("a UTF-8 path");
    let args = ["ragdoll", path, "--clip", "Walk", "--time", "0.25", "--seconds", "2", "--json"];
    let out = kloub_ok(&args);
    assert_eq!(out, kloub_ok(&args), "the same input gives the same output");
    let doc: serde_json::Value = serde_json::from_slice(&out).expect("JSON");
    assert_eq!(doc["asset"], "Fox.glb");
    assert_eq!(doc["clip"]["name"], "Walk");
    assert_eq!(doc["hz"], 60.0);
    let joints = doc["joints"].as_array().expect("joints").len();
    assert_eq!(joints, 24);
    let frames = doc["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 121, "the start and 120 steps");
    let ys = |f: &serde_json::Value| -> Vec<f64> {
        let p = f["positions"].as_array().expect("positions");
        assert_eq!(p.len(), joints * 3);
        p.iter().map(|v| v.as_f64().expect("a finite number")).skip(1).step_by(3).collect()
    };
    let top = |f| ys(f).into_iter().fold(f64::NEG_INFINITY, f64::max);
    let (first, last) = (top(&frames[0]), top(&frames[120]));
    assert!(last < first - 10.0, "the fox fell: highest joint {first} -> {last}");
    let ground = doc["ground"].as_f64().expect("ground");
    assert!(ys(&frames[120]).iter().all(|&y| y > ground - 2.0), "no joint under the ground {ground}");

    let bad = kloub().args(["ragdoll", path, "--seconds=-1"]).output().expect("run");
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--seconds -1"), "{}", String::from_utf8_lossy(&bad.stderr));
    let cube = shared_assets().join("khronos/BoxAnimated/glTF-Binary/BoxAnimated.glb");
    let none = kloub().args(["ragdoll", cube.to_str().expect("path"), "--seconds", "1"]).output().expect("run");
    assert_eq!(none.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&none.stderr).contains("no skin"), "{}", String::from_utf8_lossy(&none.stderr));
}

#[test]
fn ragdoll_falls_onto_obstacles_and_refuses_bad_ones_by_pointer() {
    let file = fox();
    let path = file.to_str().expect("a UTF-8 path");
    let base = ["ragdoll", path, "--clip", "Walk", "--time", "0.25", "--seconds", "4"];
    let doc = |out: &[u8]| -> serde_json::Value { serde_json::from_slice(out).expect("JSON") };
    let plain = doc(&kloub_ok(&base));
    // Four slabs a fifth of the fox's height around its feet, clear of the standing fox: whichever
    // way it falls, it lies on one.
    let start: Vec<f64> =
        plain["frames"][0]["positions"].as_array().expect("positions").iter().filter_map(|v| v.as_f64()).collect();
    let points: Vec<[f64; 3]> = start.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let ground = plain["ground"].as_f64().expect("ground");
    let height = points.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max) - ground;
    let low: Vec<&[f64; 3]> = points.iter().filter(|p| p[1] < ground + 0.3 * height).collect();
    let span = |k: usize| {
        let v = low.iter().map(|p| p[k]);
        (v.clone().fold(f64::INFINITY, f64::min), v.fold(f64::NEG_INFINITY, f64::max))
    };
    let ((fx0, fx1), (fz0, fz1)) = (span(0), span(2));
    let (g, t, far) = (0.12 * height, 0.2 * height, 1.5 * height);
    let slab = |xa: f64, xb: f64, za: f64, zb: f64| {
        serde_json::json!({"shape": "box", "center": [(xa + xb) / 2.0, ground + t / 2.0, (za + zb) / 2.0],
                           "size": [xb - xa, t, zb - za]})
    };
    let slab = serde_json::json!([
        slab(fx0 - g - far, fx1 + g + far, fz1 + g, fz1 + g + far),
        slab(fx0 - g - far, fx1 + g + far, fz0 - g - far, fz0 - g),
        slab(fx0 - g - far, fx0 - g, fz0 - g, fz1 + g),
        slab(fx1 + g, fx1 + g + far, fz0 - g, fz1 + g),
    ]);
    let dir = std::env::temp_dir().join(format!("kloub-obstacles-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temp dir");
    let slab_file = dir.join("slab.json");
    std::fs::write(&slab_file, slab.to_string()).expect("write");
    let mut args: Vec<&str> = base.to_vec();
    args.extend(["--obstacles", slab_file.to_str().expect("path")]);
    let out = kloub_ok(&args);
    assert_eq!(out, kloub_ok(&args), "the same world gives the same output");
    let on = doc(&out);
    assert_eq!(on["obstacles"], 4);
    // The joints' mean height at the end (joints that never move, the skeleton's root, left out).
    let start_ys: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let mean = |d: &serde_json::Value| {
        let last = &d["frames"][240]["positions"];
        let ys: Vec<f64> =
            last.as_array().expect("positions").iter().skip(1).step_by(3).filter_map(|v| v.as_f64()).collect();
        let moving: Vec<f64> = ys.iter().zip(&start_ys).filter(|(a, b)| a != b).map(|(a, _)| *a).collect();
        moving.iter().sum::<f64>() / moving.len().max(1) as f64
    };
    // On the slabs the fox lies higher than on the floor, by most of their height.
    assert!(
        mean(&on) > mean(&plain) + 0.5 * t,
        "on the slabs the joints rest at {} on average, on the floor at {} (slabs {t} high)",
        mean(&on),
        mean(&plain)
    );
    // Powered at strength 1 it keeps walking on its feet: its highest joint stays up.
    let mut powered: Vec<&str> = base.to_vec();
    powered.extend(["--strength", "1"]);
    let up = doc(&kloub_ok(&powered));
    assert_eq!(up["strength"], 1.0);
    let top = |d: &serde_json::Value| {
        d["frames"][240]["positions"]
            .as_array()
            .expect("positions")
            .iter()
            .skip(1)
            .step_by(3)
            .filter_map(|v| v.as_f64())
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(
        top(&up) > ground + 0.8 * height,
        "the powered fox fell: its highest joint at {} (standing {})",
        top(&up),
        ground + height
    );
    assert!(top(&plain) < ground + 0.8 * height, "the limp fox did not fall: {}", top(&plain));
    // Bad obstacles: an error with the pointer in that file, exit 1.
    let bad_file = dir.join("bad.json");
    std::fs::write(&bad_file, r#"[{"shape": "sphere", "center": [0, 0, 0], "radius": -1}]"#).expect("write");
    let mut args: Vec<&str> = base.to_vec();
    args.extend(["--obstacles", bad_file.to_str().expect("path")]);
    let bad = kloub().args(&args).output().expect("run");
    assert_eq!(bad.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("/0/radius") && stderr.contains("bad.json"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Zips `files` (archive path, file on disk) with deflate into `dir/name`.
fn zip_files(dir: &std::path::Path, name: &str, files: &[(&str, PathBuf)]) -> PathBuf {
    use std::io::Write;
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (inner, path) in files {
        out.start_file(*inner, options).expect("start");
        out.write_all(&std::fs::read(path).expect("read")).expect("write");
    }
    let path = dir.join(name);
    std::fs::write(&path, out.finish().expect("finish").into_inner()).expect("write zip");
    path
}

/// `kloub inspect` and `kloub pose` read a zipped glTF folder in memory, the same as the folder itself.
#[test]
fn inspect_and_pose_read_a_zipped_gltf_folder() {
    let dir = std::env::temp_dir().join(format!("kloub-cli-zip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("mkdir");
    let cesium = shared_assets().join("khronos/CesiumMan/glTF");
    let files: Vec<(&str, PathBuf)> = [
        ("CesiumMan/glTF/CesiumMan.gltf", "CesiumMan.gltf"),
        ("CesiumMan/glTF/CesiumMan_data.bin", "CesiumMan_data.bin"),
        ("CesiumMan/glTF/CesiumMan_img0.jpg", "CesiumMan_img0.jpg"),
        ("../escape.bin", "CesiumMan_data.bin"),
    ]
    .into_iter()
    .map(|(inner, file)| (inner, cesium.join(file)))
    .collect();
    let archive = zip_files(&dir, "CesiumMan.zip", &files);

    let out = kloub().arg("inspect").arg(&archive).arg("--json").output().expect("runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(doc["asset"], "CesiumMan.zip/CesiumMan/glTF/CesiumMan.gltf");
    assert_eq!(doc["skins"][0]["joints"].as_array().map(Vec::len), Some(19));
    let warnings = doc["warnings"].to_string();
    assert!(warnings.contains("../escape.bin"), "the climbing name is reported: {warnings}");

    let pose = |file: &std::path::Path| {
        let out = kloub().arg("pose").arg(file).args(["--time", "0.5"]).output().expect("runs");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
        doc["frames"].clone()
    };
    assert_eq!(pose(&archive), pose(&cesium.join("CesiumMan.gltf")), "the same frames from the zip as from the folder");

    // Two models: the first is shown, the others named in a warning; no model: an error.
    let two = zip_files(
        &dir,
        "two.zip",
        &[("a/Fox.glb", shared_assets().join("khronos/Fox/glTF-Binary/Fox.glb")), ("b/Simple.glb", rigged_simple())],
    );
    let out = kloub().arg("inspect").arg(&two).arg("--json").output().expect("runs");
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(doc["asset"], "two.zip/a/Fox.glb");
    assert!(doc["warnings"].to_string().contains("holds 2 models"), "{}", doc["warnings"]);
    let none = zip_files(&dir, "none.zip", &[("readme.txt", cesium.join("CesiumMan.gltf"))]);
    let out = kloub().arg("pose").arg(&none).output().expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("holds no .glb or .gltf model"));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

/// `kloub pose --skinning sjbbe --examples SIDECAR --rotate JOINT:q`: CesiumMan's left elbow
/// with one example pose whose inline offsets lift its support by 0.01. At the example's
/// rotation the support (the upper arm's vertices off the torso) is lifted by exactly that
/// (SJB rotates the offset), every other vertex is SJB's; at the rest pose SJBBE is SJB;
/// a broken sidecar names its pointer.
#[test]
fn pose_sjbbe_applies_example_poses_from_a_sidecar() {
    use kloub_core::examples::{ExampleShape, Examples, JointExample};
    let file = shared_assets().join("khronos/CesiumMan/glTF-Binary/CesiumMan.glb");
    let dir = std::env::temp_dir().join(format!("kloub-sjbbe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let joint = "Skeleton_arm_joint_L__3_";
    let q = "0,0,0.5,0.8660254";
    // The sidecar as the viewer saves it (inline offsets in base64).
    let bytes = std::fs::read(&file).expect("CesiumMan");
    let asset = kloub_core::import(&bytes, &kloub_core::NoResolver, &Default::default()).expect("imports").asset;
    let node = asset.nodes.iter().position(|n| n.name.as_deref() == Some(joint)).expect("the elbow") as u32;
    let examples = Examples {
        poses: vec![JointExample {
            node,
            mesh: 0,
            rotation: kloub_core::math::Quat::from_xyzw(0.0, 0.0, 0.5, 0.866_025_4),
            shape: ExampleShape::Inline { positions: vec![[0.0, 0.01, 0.0]; 3273], normals: Vec::new() },
            pointer: String::new(),
        }],
        sigma: Vec::new(),
    };
    let sidecar = serde_json::Value::Object(examples.to_json(&asset));
    let path = dir.join("CesiumMan.kloub.json");
    std::fs::write(&path, sidecar.to_string()).expect("write");
    let sidecar_arg = path.to_str().expect("UTF-8");
    let rotate = format!("{joint}:{q}");
    let bent = ["--rest", "--rotate", rotate.as_str()];
    let sjbbe = pose_json(&file, &[&bent[..], &["--skinning", "sjbbe", "--examples", sidecar_arg]].concat());
    assert_eq!(sjbbe["skinning"], "sjbbe");
    let sjb = pose_json(&file, &[&bent[..], &["--skinning", "sjb"]].concat());
    let (a, b) = (positions(&sjbbe), positions(&sjb));
    let moved: Vec<f64> =
        a.iter().zip(&b).map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()).collect();
    let lifted = moved.iter().filter(|&&d| (d - 0.01).abs() < 1e-4).count();
    let still = moved.iter().filter(|&&d| d < 1e-6).count();
    assert!(lifted > 50, "{lifted} vertices lifted by the example");
    assert_eq!(lifted + still, moved.len(), "every vertex is either lifted by 0.01 or SJB's");
    // The rest pose: no example weight.
    let rest = pose_json(&file, &["--rest", "--skinning", "sjbbe", "--examples", sidecar_arg]);
    let rest_sjb = pose_json(&file, &["--rest", "--skinning", "sjb"]);
    let d = positions(&rest)
        .iter()
        .zip(positions(&rest_sjb))
        .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(d < 1e-6, "rest pose differs from SJB by {d}");
    // A broken sidecar and a bad --rotate are errors with their pointer or argument.
    std::fs::write(&path, r#"{"examples": {"Skeleton_arm_joint_L__3_": [{"rotation": [0, 0, 2, 0], "offsets": ""}]}}"#)
        .expect("write");
    let out =
        kloub().arg("pose").arg(&file).args(["--skinning", "sjbbe", "--examples", sidecar_arg]).output().expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("/examples/Skeleton_arm_joint_L__3_/0/rotation: not a unit quaternion"), "{stderr}");
    let out = kloub().arg("pose").arg(&file).args(["--rotate", "nobody:0,0,0,1"]).output().expect("runs");
    assert!(String::from_utf8_lossy(&out.stderr).contains("no joint named \"nobody\""));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}
