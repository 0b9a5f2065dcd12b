//! The `kloub` binary as users run it: exit codes, stdout/stderr, `serve` start-up and shutdown.

mod common;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn kloub() -> Command {
    Command::new(env!("CARGO_BIN_EXE_kloub"))
}

/// `../shared/assets` beside the checkout, overridable with `KLOUB_SHARED_ASSETS`.
fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/assets"))
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
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(doc["asset"], "RiggedSimple.glb");
    assert_eq!(doc["clip"]["index"], 0);
    assert_eq!(doc["frames"].as_array().expect("frames").len(), 2);
    // serde_json's default parser may be 1 ulp off in f64; narrowing gives the f32 back.
    let time = doc["frames"][1]["time"].as_f64().expect("a number");
    assert_eq!(time as f32, 1.04f32);
    assert!(
        (time - f64::from(1.04f32)).abs() <= 2.0 * f64::EPSILON,
        "full f32 precision"
    );
}

#[test]
fn pose_errors_name_file_and_pointer_and_exit_1() {
    let file = rigged_simple();
    let out = kloub()
        .arg("pose")
        .arg(&file)
        .args(["--clip", "Nope"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    let err = String::from_utf8_lossy(&out.stderr);
    let want = format!(
        "kloub: {}: /animations: no clip \"Nope\"; available: 0",
        file.display()
    );
    assert!(err.starts_with(&want), "{err}");

    let out = kloub()
        .args(["pose", "/nonexistent/x.glb"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("kloub: /nonexistent/x.glb: cannot read: "),
        "{err}"
    );

    let out = kloub()
        .args(["pose", "x.glb", "--rest", "--clip", "0"])
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2), "usage error");
}

#[test]
fn pose_refuses_external_files_leaving_the_folder() {
    let base = common::temp_dir("cli-escape");
    std::fs::create_dir_all(base.join("model")).expect("mkdir");
    std::fs::write(base.join("outside.bin"), [0u8; 12]).expect("write");
    #[cfg(unix)]
    std::os::unix::fs::symlink(base.join("outside.bin"), base.join("model/link.bin"))
        .expect("symlink");
    let mut uris = vec!["../outside.bin", "%2e%2e/outside.bin"];
    if cfg!(unix) {
        uris.push("link.bin");
    }
    for uri in uris {
        let gltf = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":12}}]}}"#
        );
        let file = base.join("model/escape.gltf");
        std::fs::write(&file, gltf).expect("write");
        let out = kloub().arg("pose").arg(&file).output().expect("runs");
        assert_eq!(out.status.code(), Some(1), "{uri}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.starts_with(&format!("kloub: {}: /buffers/0", file.display())),
            "{err}"
        );
        assert!(
            err.contains("outside") || err.contains("refused"),
            "{uri}: {err}"
        );
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
    BufReader::new(stdout)
        .read_line(&mut line)
        .expect("a first line");
    let addr = line
        .trim()
        .strip_prefix("kloub serve: listening on http://")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"));
    let addr = addr.parse().expect("a socket address");

    let reply = common::request(addr, "GET", "/models/default.glb", &[]);
    assert_eq!(
        (reply.status, reply.body.as_slice()),
        (200, b"fox".as_slice())
    );
    assert_eq!(common::request(addr, "GET", "/", &[]).text(), "<p>hi</p>");

    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    assert!(killed.expect("kill runs").success());
    let status = child.wait().expect("exits");
    assert!(status.success(), "graceful shutdown exits 0, got {status}");
    std::fs::remove_dir_all(&base).expect("cleanup");
}
