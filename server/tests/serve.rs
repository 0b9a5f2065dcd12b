//! `kloub serve` end to end, what it answers: the real server on 127.0.0.1 and hyper's client.
//! Every behaviour is checked in both modes: files from disk (`--dist`/`--assets`) and files
//! from memory (as the bundle embedded in the binary is served).

mod common;

use common::{BIG_LEN, Http, Reply, Site, gunzip, repo, sample_bytes, site, start, unbrotli};
use kloub_server::serve::{CSP, MemoryDir, ServeConfig, Source, embedded, files};

const HTML: &str = "text/html; charset=utf-8";

/// Runs `check` against the site served from disk, then from memory.
fn both_modes(tag: &str, check: impl Fn(&Http, &Site, &str)) {
    let site = site(tag);
    for (mode, config) in [("disk", site.disk_config()), ("memory", site.memory_config())] {
        let server = start(&config);
        check(&Http::new(server.addr), &site, mode);
        server.stop();
    }
}

fn assert_file(reply: &Reply, content_type: &str, body: &[u8], what: &str) {
    assert_eq!(reply.status, 200, "{what}: {reply:?}");
    assert_eq!(reply.header("content-type"), Some(content_type), "{what}");
    assert_eq!(reply.header("x-content-type-options"), Some("nosniff"), "{what}");
    assert_eq!(reply.header("accept-ranges"), Some("bytes"), "{what}");
    let etag = reply.header("etag").unwrap_or_default();
    assert!(etag.len() > 2 && etag.starts_with('"') && etag.ends_with('"'), "{what}: strong ETag, got {etag:?}");
    assert_eq!(reply.body, body, "{what}");
}

#[test]
fn serves_bundle_and_library_with_exact_types_and_headers() {
    both_modes("serve-types", |http, site, mode| {
        let index = site.read_dist("index.html");
        for path in ["/", "/index.html"] {
            let r = http.get(path, &[]);
            assert_file(&r, HTML, &index, &format!("{mode} {path}"));
            assert_eq!(r.header("content-security-policy"), Some(CSP), "{mode} {path}");
            assert_eq!(r.header("cache-control"), Some("no-cache"), "{mode} {path}");
            assert_eq!(r.header("access-control-allow-origin"), None, "{mode}: bundle not CORS");
        }
        let csp = CSP.to_owned();
        assert!(csp.contains("'wasm-unsafe-eval'") && !csp.contains("'unsafe-eval'"));

        let js = http.get("/kloub_web.js?v=1", &[]);
        assert_file(&js, "text/javascript", b"export default 1;", mode);
        assert_eq!(js.header("content-security-policy"), None, "{mode}: CSP only on HTML");
        let wasm = http.get("/kloub_web_bg.wasm", &[]);
        assert_file(&wasm, "application/wasm", &site.read_dist("kloub_web_bg.wasm"), mode);
        assert_eq!(wasm.header("content-encoding"), None, "{mode}: no Accept-Encoding");
        assert_eq!(wasm.header("vary"), Some("Accept-Encoding"), "{mode}");
        assert_file(&http.get("/style.css", &[]), "text/css; charset=utf-8", b"body{}", mode);
        let hashed = http.get("/app.0123456789abcdef.js", &[]);
        assert_file(&hashed, "text/javascript", b"hashed", mode);
        assert_eq!(
            hashed.header("cache-control"),
            Some("public, max-age=31536000, immutable"),
            "{mode}: content-hashed names are immutable"
        );

        let fox = std::fs::read(site.assets.join("Fox.glb")).expect("fixture");
        for path in ["/models/default.glb", "/assets/Fox.glb"] {
            let r = http.get(path, &[]);
            assert_file(&r, "model/gltf-binary", &fox, &format!("{mode} {path}"));
            assert_eq!(r.header("access-control-allow-origin"), Some("*"), "{mode} {path}");
            assert_eq!(r.header("cross-origin-resource-policy"), Some("cross-origin"));
        }
        assert_file(&http.get("/assets/sub/Man.gltf", &[]), "model/gltf+json", b"{}", mode);
        assert_file(&http.get("/assets/sub/Man.bin", &[]), "application/octet-stream", &[0u8; 4], mode);
        assert_file(
            &http.get("/big.bin", &[]),
            "application/octet-stream",
            &sample_bytes(BIG_LEN, 3),
            &format!("{mode}: a file over 1 MiB (streamed from disk)"),
        );
    });
}

#[test]
fn precompressed_siblings_are_chosen_by_accept_encoding() {
    both_modes("serve-encoding", |http, site, mode| {
        let wasm = site.read_dist("kloub_web_bg.wasm");
        let identity = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "identity")]);
        let gz = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip, deflate")]);
        assert_eq!(gz.status, 200, "{mode}");
        assert_eq!(gz.header("content-encoding"), Some("gzip"), "{mode}");
        assert_eq!(gz.header("content-type"), Some("application/wasm"), "{mode}");
        assert_eq!(gz.header("vary"), Some("Accept-Encoding"), "{mode}");
        assert_eq!(gz.header("x-content-type-options"), Some("nosniff"));
        // sample_bytes carries ~4 bits per byte under Huffman coding: gzip gets it to about half.
        assert!(gz.body.len() < wasm.len() * 3 / 4, "{mode}: really compressed");
        assert_eq!(gunzip(&gz.body), wasm, "{mode}: gzip decodes to the original");
        assert_ne!(gz.header("etag"), identity.header("etag"), "{mode}: ETag per encoding");
        assert_eq!(identity.header("content-encoding"), None);
        assert_eq!(identity.body, wasm);

        let br = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip, br")]);
        assert_eq!(br.header("content-encoding"), Some("br"), "{mode}: br preferred");
        assert_eq!(br.header("content-type"), Some("application/wasm"));
        assert_eq!(br.body, site.read_dist("kloub_web_bg.wasm.br"), "{mode}");
        let refused = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "br;q=0, gzip;q=0")]);
        assert_eq!(refused.header("content-encoding"), None, "{mode}: q=0 refuses");
        assert_eq!(refused.body, wasm);
        let head = http.send("HEAD", "/kloub_web_bg.wasm", &[("accept-encoding", "gzip")], None);
        assert_eq!(head.header("content-encoding"), Some("gzip"));
        assert_eq!(head.header("content-length").map(str::to_owned), Some(gz.body.len().to_string()));
        assert!(head.body.is_empty());
        // A file without siblings is sent as is, without Vary.
        let js = http.get("/kloub_web.js", &[("accept-encoding", "gzip, br")]);
        assert_eq!((js.header("content-encoding"), js.header("vary")), (None, None));
    });
}

#[test]
fn stale_siblings_on_disk_are_not_served() {
    let site = site("serve-stale");
    let wasm = site.dist.join("kloub_web_bg.wasm");
    let old = std::fs::File::options().write(true).open(site.dist.join("kloub_web_bg.wasm.gz")).expect("open");
    old.set_modified(std::time::UNIX_EPOCH).expect("set mtime");
    let server = start(&site.disk_config());
    let reply = Http::new(server.addr).get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip")]);
    assert_eq!(reply.header("content-encoding"), None, "the .gz is older than the file");
    assert_eq!(reply.body, std::fs::read(wasm).expect("read"));
}

#[test]
fn strong_etags_answer_304() {
    both_modes("serve-etag", |http, _site, mode| {
        let first = http.get("/kloub_web.js", &[]);
        let etag = first.header("etag").expect("an ETag").to_owned();
        assert!(!etag.starts_with("W/"), "{mode}: strong");
        if mode == "memory" {
            assert_eq!(etag, files::content_etag(b"export default 1;"), "content hash");
        }
        for matching in [etag.clone(), format!("W/{etag}"), format!("\"x\", {etag}"), "*".into()] {
            let r = http.get("/kloub_web.js", &[("if-none-match", &matching)]);
            assert_eq!(r.status, 304, "{mode}: If-None-Match: {matching}");
            assert!(r.body.is_empty());
            assert_eq!(r.header("etag"), Some(etag.as_str()));
            assert_eq!(r.header("cache-control"), Some("no-cache"));
            assert_eq!(r.header("x-content-type-options"), Some("nosniff"));
        }
        let other = http.get("/kloub_web.js", &[("if-none-match", "\"other\"")]);
        assert_eq!((other.status, other.body.as_slice()), (200, b"export default 1;".as_slice()));
        let gz = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip")]);
        let gz_tag = gz.header("etag").expect("ETag").to_owned();
        let r = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip"), ("if-none-match", &gz_tag)]);
        assert_eq!(r.status, 304, "{mode}: 304 for the compressed representation");
        let r = http.get("/kloub_web_bg.wasm", &[("if-none-match", &gz_tag)]);
        assert_eq!(r.status, 200, "{mode}: another representation, another ETag");
        let api = http.get("/api/assets", &[]);
        let api_tag = api.header("etag").expect("the index has an ETag").to_owned();
        assert_eq!(http.get("/api/assets", &[("if-none-match", &api_tag)]).status, 304);
    });

    // On disk the ETag follows the file.
    let site = site("serve-etag-change");
    let server = start(&site.disk_config());
    let http = Http::new(server.addr);
    let before = http.get("/style.css", &[]).header("etag").map(str::to_owned);
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::write(site.dist.join("style.css"), "body{margin:0}").expect("write");
    let after = http.get("/style.css", &[("if-none-match", before.as_deref().unwrap_or_default())]);
    assert_eq!(after.status, 200, "a changed file is sent again");
    assert_eq!(after.body, b"body{margin:0}");
    assert_ne!(after.header("etag").map(str::to_owned), before);
}

#[test]
fn ranges_and_head() {
    both_modes("serve-range", |http, site, mode| {
        let fox = std::fs::read(site.assets.join("Fox.glb")).expect("fixture");
        let len = fox.len();
        let r = http.get("/models/default.glb", &[("range", "bytes=0-3")]);
        assert_eq!(r.status, 206, "{mode}");
        assert_eq!(r.body, b"glTF");
        assert_eq!(r.header("content-range"), Some(format!("bytes 0-3/{len}").as_str()));
        assert_eq!(r.header("content-length"), Some("4"));
        assert_eq!(r.header("content-type"), Some("model/gltf-binary"));
        assert_eq!(r.header("access-control-allow-origin"), Some("*"));
        let r = http.get("/assets/Fox.glb", &[("range", "bytes=-10")]);
        assert_eq!((r.status, r.body.as_slice()), (206, &fox[len - 10..]), "{mode}: suffix");
        let r = http.get("/assets/Fox.glb", &[("range", format!("bytes={len}-").as_str())]);
        assert_eq!(r.status, 416, "{mode}");
        assert_eq!(r.header("content-range"), Some(format!("bytes */{len}").as_str()));
        let etag = http.get("/assets/Fox.glb", &[]).header("etag").expect("ETag").to_owned();
        let r = http.get("/assets/Fox.glb", &[("range", "bytes=4-7"), ("if-range", &etag)]);
        assert_eq!((r.status, r.body.as_slice()), (206, &fox[4..8]), "{mode}: If-Range matches");
        let r = http.get("/assets/Fox.glb", &[("range", "bytes=4-7"), ("if-range", "\"old\"")]);
        assert_eq!((r.status, r.body.len()), (200, len), "{mode}: If-Range differs: whole file");
        let r = http.get("/assets/Fox.glb", &[("range", "bytes=0-1,4-5")]);
        assert_eq!((r.status, r.body.len()), (200, len), "{mode}: several ranges: whole file");

        let big = sample_bytes(BIG_LEN, 3);
        let r = http.get("/big.bin", &[("range", "bytes=1048570-2097160")]);
        assert_eq!(r.status, 206, "{mode}");
        assert_eq!(r.body, &big[1_048_570..=2_097_160], "{mode}: a large range");

        let head = http.send("HEAD", "/kloub_web_bg.wasm", &[], None);
        assert_eq!(head.status, 200);
        assert_eq!(head.header("content-type"), Some("application/wasm"));
        let wasm_len = site.read_dist("kloub_web_bg.wasm").len().to_string();
        assert_eq!(head.header("content-length"), Some(wasm_len.as_str()), "{mode}");
        assert!(head.header("etag").is_some());
        assert!(head.body.is_empty(), "{mode}: HEAD has no body");
        let head = http.send("HEAD", "/", &[], None);
        assert_eq!(head.header("content-security-policy"), Some(CSP));
        assert!(head.body.is_empty());
        let head = http.send("HEAD", "/assets/Fox.glb", &[("range", "bytes=0-3")], None);
        assert_eq!((head.status, head.header("content-length")), (206, Some("4")));
        assert!(head.body.is_empty());
    });
}

#[test]
fn library_routes_allow_any_origin_and_preflights() {
    both_modes("serve-cors", |http, _site, mode| {
        for path in ["/api/assets", "/assets/Fox.glb", "/models/default.glb", "/assets/missing.glb"] {
            let r = http.get(path, &[("origin", "https://elsewhere.example")]);
            assert_eq!(r.header("access-control-allow-origin"), Some("*"), "{mode} {path}");
            assert_eq!(r.header("x-content-type-options"), Some("nosniff"));
            let pre = http.send(
                "OPTIONS",
                path,
                &[
                    ("origin", "https://elsewhere.example"),
                    ("access-control-request-method", "GET"),
                    ("access-control-request-headers", "range"),
                ],
                None,
            );
            assert_eq!(pre.status, 204, "{mode} {path}");
            assert!(pre.body.is_empty());
            assert_eq!(pre.header("access-control-allow-origin"), Some("*"));
            assert_eq!(pre.header("access-control-allow-methods"), Some("GET, HEAD"));
            assert_eq!(pre.header("access-control-allow-headers"), Some("*"));
            assert_eq!(pre.header("allow"), Some("GET, HEAD, OPTIONS"));
        }
        for path in ["/", "/kloub_web.js", "/missing"] {
            let r = http.get(path, &[("origin", "https://elsewhere.example")]);
            assert_eq!(r.header("access-control-allow-origin"), None, "{mode} {path}");
            let pre = http.send("OPTIONS", path, &[], None);
            assert_eq!(pre.status, 405, "{mode} {path}: no preflight on the bundle");
            assert_eq!(pre.header("allow"), Some("GET, HEAD"));
        }
    });
}

#[test]
fn other_methods_are_405_and_bodies_413() {
    both_modes("serve-methods", |http, _site, mode| {
        for method in ["POST", "PUT", "DELETE", "PATCH", "TRACE"] {
            for (path, allow) in [
                ("/", "GET, HEAD"),
                ("/kloub_web.js", "GET, HEAD"),
                ("/api/assets", "GET, HEAD, OPTIONS"),
                ("/assets/Fox.glb", "GET, HEAD, OPTIONS"),
            ] {
                let r = http.send(method, path, &[], None);
                assert_eq!(r.status, 405, "{mode} {method} {path}");
                assert_eq!(r.header("allow"), Some(allow), "{mode} {method} {path}");
                assert_eq!(r.header("x-content-type-options"), Some("nosniff"));
            }
        }
        for method in ["POST", "PUT", "GET"] {
            for path in ["/", "/api/assets", "/assets/Fox.glb"] {
                let r = http.send(method, path, &[], Some(b"{\"a\":1}"));
                assert_eq!(r.status, 413, "{mode} {method} {path} with a body");
                assert_eq!(r.header("x-content-type-options"), Some("nosniff"));
            }
        }
    });
    // Chunked bodies, sent raw.
    let site = site("serve-chunked");
    let server = start(&site.disk_config());
    let raw = common::raw(
        server.addr,
        b"POST /api/assets HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\n",
    );
    let reply = common::parse(&raw, false);
    assert_eq!(reply.status, 413);
    assert_eq!(reply.header("connection"), Some("close"));
}

#[test]
fn api_assets_lists_models_with_files_licences_clips_and_errors() {
    let site = site("serve-index");
    let cesium = common::shared_assets().join("khronos/CesiumMan/glTF");
    let man = site.assets.join("men/Cesium Man");
    std::fs::create_dir_all(&man).expect("mkdir");
    for f in ["CesiumMan.gltf", "CesiumMan_data.bin", "CesiumMan_img0.jpg"] {
        std::fs::copy(cesium.join(f), man.join(f)).expect("the shared CesiumMan glTF");
    }
    std::fs::copy(cesium.join("../LICENSE.md"), site.assets.join("men/LICENSE.md")).expect("copy");
    for (mode, config) in [("disk", site.disk_config()), ("memory", site.memory_config())] {
        let server = start(&config);
        let http = Http::new(server.addr);
        let api = http.get("/api/assets", &[]);
        assert_eq!(api.status, 200, "{mode}");
        assert_eq!(api.header("content-type"), Some("application/json"));
        assert_eq!(api.header("access-control-allow-origin"), Some("*"));
        let json: serde_json::Value = serde_json::from_slice(&api.body).expect("JSON");
        let entries = json.as_array().expect("an array");
        let names: Vec<&str> = entries.iter().map(|e| e["name"].as_str().unwrap_or("?")).collect();
        assert_eq!(names, ["Fox", "CesiumMan", "Man"], "{mode}: sorted by path");

        let fox = &entries[0];
        assert_eq!(fox["url"], "/assets/Fox.glb");
        assert_eq!(fox["files"], serde_json::json!(["/assets/Fox.glb"]));
        assert_eq!(fox["licence"], "CC0 fox");
        assert_eq!(fox["attribution"], "CC0 fox");
        assert_eq!(fox["default"], true, "{mode}: Fox.glb is what /models/default.glb serves");
        assert_eq!(fox["clips"], serde_json::json!(["Survey", "Walk", "Run"]));
        assert_eq!(fox["joints"], 24);
        assert!(fox.get("error").is_none(), "{mode}: {fox}");

        let cesium_entry = &entries[1];
        assert_eq!(cesium_entry["url"], "/assets/men/Cesium%20Man/CesiumMan.gltf");
        let files: Vec<&str> =
            cesium_entry["files"].as_array().expect("files").iter().filter_map(|f| f.as_str()).collect();
        assert_eq!(files[0], "/assets/men/Cesium%20Man/CesiumMan.gltf");
        let mut rest = files[1..].to_vec();
        rest.sort_unstable();
        assert_eq!(
            rest,
            ["/assets/men/Cesium%20Man/CesiumMan_data.bin", "/assets/men/Cesium%20Man/CesiumMan_img0.jpg"],
            "{mode}: the .gltf's buffer and image"
        );
        let total: u64 = ["CesiumMan.gltf", "CesiumMan_data.bin", "CesiumMan_img0.jpg"]
            .iter()
            .map(|f| man.join(f).metadata().expect("meta").len())
            .sum();
        assert_eq!(cesium_entry["size"], total);
        assert_eq!(cesium_entry["joints"], 19);
        assert_eq!(cesium_entry["clips"].as_array().map(Vec::len), Some(1));
        let licence = cesium_entry["licence"].as_str().unwrap_or_default();
        assert!(licence.contains("Cesium Man"), "{mode}: the folder above's LICENSE.md");
        assert_eq!(cesium_entry["default"], false);

        let broken = &entries[2];
        assert_eq!(broken["url"], "/assets/sub/Man.gltf");
        assert!(broken["error"].as_str().is_some_and(|e| !e.is_empty()), "{mode}: {broken}");
        assert_eq!(broken["licence"], serde_json::Value::Null);
        assert_eq!(broken["size"], 2);

        // Every listed file is served, with its exact type.
        for entry in entries {
            for url in entry["files"].as_array().expect("files") {
                let url = url.as_str().expect("a URL");
                let r = http.get(url, &[]);
                assert_eq!(r.status, 200, "{mode}: {url}");
            }
        }
        let jpg = http.get("/assets/men/Cesium%20Man/CesiumMan_img0.jpg", &[]);
        assert_eq!(jpg.header("content-type"), Some("image/jpeg"));
        server.stop();
    }
}

#[test]
fn without_a_bundle_the_page_says_how_to_build_it() {
    let base = common::temp_dir("serve-unbuilt");
    for config in [
        ServeConfig {
            dist: Source::Dir(base.join("no-dist")),
            assets: Source::Dir(base.join("no-assets")),
            limits: Default::default(),
            connect_src: None,
        },
        ServeConfig {
            dist: Source::Memory(MemoryDir::default()),
            assets: Source::Memory(MemoryDir::default()),
            limits: Default::default(),
            connect_src: None,
        },
    ] {
        let server = start(&config);
        let http = Http::new(server.addr);
        let reply = http.get("/", &[]);
        assert_eq!(reply.status, 500);
        assert_eq!(reply.header("content-type"), Some(HTML));
        assert_eq!(reply.header("x-content-type-options"), Some("nosniff"));
        assert_eq!(reply.header("content-security-policy"), Some(CSP));
        assert!(reply.text().contains("web bundle not built: run <code>./scripts/run.sh</code>"));
        let api = http.get("/api/assets", &[]);
        assert_eq!((api.status, api.text().as_str()), (200, "[]"));
        assert_eq!(http.get("/models/default.glb", &[]).status, 404);
        assert_eq!(http.get("/kloub_web.js", &[]).status, 404);
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// The embedded tables hold exactly `web/dist` and `web/assets` as they were at build time
/// (cargo rebuilds when they change), and the default configuration serves them.
#[test]
fn the_default_configuration_serves_the_embedded_bundle_and_samples() {
    let assets = repo().join("web/assets");
    let dist = repo().join("web/dist");
    let on_disk = |dir: &std::path::Path| {
        let mem = if dir.is_dir() { common::memory_of(dir) } else { MemoryDir::default() };
        mem.paths().map(|p| (p.to_owned(), mem.get(p).map(|b| b.to_vec()))).collect::<Vec<_>>()
    };
    let embedded_files =
        |mem: &MemoryDir| mem.paths().map(|p| (p.to_owned(), mem.get(p).map(|b| b.to_vec()))).collect::<Vec<_>>();
    assert_eq!(embedded_files(&embedded::assets()), on_disk(&assets));
    assert!(embedded::assets().get("Fox.glb").is_some());
    assert_eq!(embedded_files(&embedded::dist()), on_disk(&dist));
    // Precompressed siblings, when built, decode to their file.
    let bundle = embedded::dist();
    for path in bundle.paths() {
        let Some(original) = path.strip_suffix(".gz").or_else(|| path.strip_suffix(".br")).and_then(|p| bundle.get(p))
        else {
            continue;
        };
        let packed = bundle.get(path).expect("listed");
        let unpacked = if path.ends_with(".gz") { gunzip(packed) } else { unbrotli(packed) };
        assert_eq!(&unpacked[..], &original[..], "{path} is stale");
    }

    let server = start(&ServeConfig::default());
    let http = Http::new(server.addr);
    let fox = std::fs::read(assets.join("Fox.glb")).expect("the bundled Fox");
    let r = http.get("/models/default.glb", &[]);
    assert_eq!((r.status, r.body.len()), (200, fox.len()));
    assert_eq!(r.body, fox);
    assert_eq!(r.header("etag").map(str::to_owned), Some(files::content_etag(&fox)));
    let index = http.get("/", &[]);
    match bundle.get("index.html") {
        Some(html) => assert_eq!((index.status, index.body.as_slice()), (200, &html[..])),
        None => assert_eq!(index.status, 500, "built before the bundle: the build hint"),
    }
    if let Some(wasm) = bundle.get("kloub_web_bg.wasm") {
        let r = http.get("/kloub_web_bg.wasm", &[("accept-encoding", "gzip")]);
        assert_eq!(r.header("content-type"), Some("application/wasm"));
        let body = if r.header("content-encoding") == Some("gzip") { gunzip(&r.body) } else { r.body };
        assert_eq!(&body[..], &wasm[..]);
    }
}

/// The sample library a fresh clone serves (the Samples menu lists it): each model imports, has
/// its licence and a one-line attribution, and Fox is the default.
#[test]
fn the_bundled_sample_library_lists_every_sample_with_its_licence() {
    let index = kloub_server::serve::index::build(&files::Root::Memory(embedded::assets()));
    let names: Vec<&str> = index.iter().map(|e| e.name.as_str()).collect();
    for want in ["Fox", "CesiumMan", "RiggedFigure", "RobotExpressive", "Knight", "AnimatedMorphSphere"] {
        assert!(names.contains(&want), "{want} missing from the library: {names:?}");
    }
    for entry in &index {
        assert_eq!(entry.error, None, "{}", entry.name);
        assert!(!entry.clips.is_empty(), "{}: every sample animates", entry.name);
        let licence = entry.licence.as_deref().unwrap_or_default();
        assert!(licence.contains("CC0") || licence.contains("CC BY 4.0"), "{}: {licence}", entry.name);
        let attribution = entry.attribution.as_deref().unwrap_or_default();
        assert!(attribution.len() > 20 && !attribution.starts_with('#'), "{}: {attribution:?}", entry.name);
    }
    let defaults: Vec<&str> = index.iter().filter(|e| e.default).map(|e| e.name.as_str()).collect();
    assert_eq!(defaults, ["Fox"]);
    let knight = index.iter().find(|e| e.name == "Knight").map(|e| e.clips.len());
    assert_eq!(knight, Some(76));
}
