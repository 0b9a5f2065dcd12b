//! `kloub serve` end to end: the real router on 127.0.0.1 and a raw HTTP/1.1 client.

mod common;

use common::{Reply, request, temp_dir};
use kloub_server::serve::{ServeConfig, router};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

/// Serves `config` on an ephemeral port in a background thread; returns the address.
fn start(config: &ServeConfig) -> SocketAddr {
    let app = router(config);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("a tokio runtime");
        runtime.block_on(async move {
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
                .await
                .expect("bind");
            tx.send(listener.local_addr().expect("local address"))
                .expect("report address");
            axum::serve(listener, app).await.expect("serve");
        });
    });
    rx.recv().expect("the server started")
}

/// A site: `dist/` with a bundle, `assets/` with models, and a secret beside them.
struct Site {
    base: PathBuf,
    config: ServeConfig,
}

fn site(tag: &str) -> Site {
    let base = temp_dir(tag);
    let dist = base.join("dist");
    let assets = base.join("assets");
    std::fs::create_dir_all(&dist).expect("mkdir");
    std::fs::create_dir_all(assets.join("sub")).expect("mkdir");
    std::fs::write(
        dist.join("index.html"),
        "<!doctype html><title>kloub</title>",
    )
    .expect("write");
    std::fs::write(dist.join("kloub_web.js"), "export default 1;").expect("write");
    std::fs::write(dist.join("kloub_web_bg.wasm"), b"\0asm\x01\0\0\0").expect("write");
    std::fs::write(dist.join("style.css"), "body{}").expect("write");
    std::fs::write(dist.join(".wasm-opt-input"), "hash").expect("write");
    std::fs::write(assets.join("Fox.glb"), b"glTF fake fox").expect("write");
    std::fs::write(assets.join("Fox.LICENSE.md"), "CC0").expect("write");
    std::fs::write(assets.join("sub/Man.gltf"), "{}").expect("write");
    std::fs::write(assets.join("sub/Man.bin"), [0u8; 4]).expect("write");
    std::fs::write(base.join("secret.txt"), "top secret").expect("write");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(base.join("secret.txt"), assets.join("link-out.txt"))
            .expect("symlink");
        std::os::unix::fs::symlink(&base, dist.join("up")).expect("symlink");
    }
    Site {
        base: base.clone(),
        config: ServeConfig { dist, assets },
    }
}

fn assert_file(reply: &Reply, content_type: &str, body: &[u8]) {
    assert_eq!(reply.status, 200, "{reply:?}");
    assert_eq!(reply.header("content-type"), Some(content_type));
    assert_eq!(reply.header("x-content-type-options"), Some("nosniff"));
    assert_eq!(reply.body, body);
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).expect("fixture exists")
}

#[test]
fn serves_bundle_models_and_index_with_exact_types() {
    let site = site("serve-ok");
    let addr = start(&site.config);
    let dist = &site.config.dist;
    let assets = &site.config.assets;

    let index = read(&dist.join("index.html"));
    assert_file(
        &request(addr, "GET", "/", &[]),
        "text/html; charset=utf-8",
        &index,
    );
    assert_file(
        &request(addr, "GET", "/index.html", &[]),
        "text/html; charset=utf-8",
        &index,
    );
    assert_file(
        &request(addr, "GET", "/kloub_web_bg.wasm", &[]),
        "application/wasm",
        &read(&dist.join("kloub_web_bg.wasm")),
    );
    assert_file(
        &request(addr, "GET", "/kloub_web.js?v=1", &[]),
        "text/javascript",
        &read(&dist.join("kloub_web.js")),
    );
    assert_file(
        &request(addr, "GET", "/style.css", &[]),
        "text/css; charset=utf-8",
        b"body{}",
    );

    let fox = read(&assets.join("Fox.glb"));
    assert_file(
        &request(addr, "GET", "/models/default.glb", &[]),
        "model/gltf-binary",
        &fox,
    );
    assert_file(
        &request(addr, "GET", "/assets/Fox.glb", &[]),
        "model/gltf-binary",
        &fox,
    );
    assert_file(
        &request(addr, "GET", "/assets/sub/Man.gltf", &[]),
        "model/gltf+json",
        b"{}",
    );
    assert_file(
        &request(addr, "GET", "/assets/sub/Man.bin", &[]),
        "application/octet-stream",
        &[0u8; 4],
    );

    let api = request(addr, "GET", "/api/assets", &[]);
    assert_eq!(api.status, 200);
    assert_eq!(api.header("content-type"), Some("application/json"));
    assert_eq!(api.header("x-content-type-options"), Some("nosniff"));
    let json: serde_json::Value = serde_json::from_slice(&api.body).expect("JSON");
    assert_eq!(
        json,
        serde_json::json!([
            {"name": "Fox", "url": "/assets/Fox.glb", "size": fox.len()},
            {"name": "Man", "url": "/assets/sub/Man.gltf", "size": 2},
        ])
    );
    // Every listed URL is served.
    for entry in json.as_array().expect("array") {
        let url = entry["url"].as_str().expect("url");
        assert_eq!(request(addr, "GET", url, &[]).status, 200, "{url}");
    }

    let head = request(addr, "HEAD", "/kloub_web_bg.wasm", &[]);
    assert_eq!(head.status, 200);
    assert_eq!(head.header("content-type"), Some("application/wasm"));
    assert_eq!(head.header("content-length"), Some("8"));
    assert!(head.body.is_empty(), "HEAD has no body");

    let range = request(
        addr,
        "GET",
        "/models/default.glb",
        &[("Range", "bytes=0-3")],
    );
    assert_eq!(range.status, 206);
    assert_eq!(range.body, b"glTF");
    assert_eq!(range.header("content-type"), Some("model/gltf-binary"));

    std::fs::remove_dir_all(&site.base).expect("cleanup");
}

#[test]
fn refuses_traversal_without_echoing_the_path() {
    let site = site("serve-traversal");
    let addr = start(&site.config);
    let vectors = [
        "/../secret.txt",
        "/assets/../secret.txt",
        "/assets/../../secret.txt",
        "/%2e%2e/secret.txt",
        "/%2E%2E/secret.txt",
        "/..%2fsecret.txt",
        "/..%2Fsecret.txt",
        "/assets/..%2fsecret.txt",
        "/assets/%2e%2e%2fsecret.txt",
        "/assets/..%5csecret.txt",
        "/assets/..\\secret.txt",
        "/%252e%252e/secret.txt",
        "/assets/%252e%252e%252fsecret.txt",
        "/c:/secret.txt",
        "/C%3A%5Csecret.txt",
        "/secret.txt%00.html",
        "/index.html%00",
        "/.wasm-opt-input",
        "/assets/link-out.txt",
        "/up/secret.txt",
        "/assets/sub/../../secret.txt",
        "/CON",
        "/assets/nul.glb",
        "/%c0%ae%c0%ae/secret.txt",
        "/%",
        "/assets/",
        "/sub",
        "/missing.html",
        "//secret.txt",
    ];
    for v in vectors {
        let reply = request(addr, "GET", v, &[]);
        assert_eq!(reply.status, 404, "{v}: {reply:?}");
        assert_eq!(
            reply.header("x-content-type-options"),
            Some("nosniff"),
            "{v}"
        );
        let text = reply.text();
        assert!(
            !text.contains("secret"),
            "{v}: the 404 echoes or leaks: {text}"
        );
        assert!(!text.contains("..") && !text.contains('%'), "{v}: {text}");
    }
    std::fs::remove_dir_all(&site.base).expect("cleanup");
}

#[test]
fn other_methods_are_405() {
    let site = site("serve-methods");
    let addr = start(&site.config);
    for method in ["POST", "PUT", "DELETE", "PATCH", "OPTIONS"] {
        for path in ["/", "/api/assets", "/assets/Fox.glb", "/kloub_web.js"] {
            let reply = request(addr, method, path, &[]);
            assert_eq!(reply.status, 405, "{method} {path}");
            assert_eq!(reply.header("allow"), Some("GET, HEAD"), "{method} {path}");
            assert_eq!(reply.header("x-content-type-options"), Some("nosniff"));
        }
    }
    std::fs::remove_dir_all(&site.base).expect("cleanup");
}

#[test]
fn missing_bundle_says_how_to_build_it() {
    let base = temp_dir("serve-unbuilt");
    let config = ServeConfig {
        dist: base.join("no-dist"),
        assets: base.join("no-assets"),
    };
    let addr = start(&config);
    let reply = request(addr, "GET", "/", &[]);
    assert_eq!(reply.status, 500);
    assert_eq!(
        reply.header("content-type"),
        Some("text/html; charset=utf-8")
    );
    assert_eq!(reply.header("x-content-type-options"), Some("nosniff"));
    assert!(
        reply
            .text()
            .contains("web bundle not built: run <code>./scripts/run.sh</code>")
    );
    let api = request(addr, "GET", "/api/assets", &[]);
    assert_eq!((api.status, api.text().as_str()), (200, "[]"));
    assert_eq!(request(addr, "GET", "/models/default.glb", &[]).status, 404);
    assert_eq!(request(addr, "GET", "/kloub_web.js", &[]).status, 404);
    std::fs::remove_dir_all(&base).expect("cleanup");
}
