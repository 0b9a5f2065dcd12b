//! `kloub serve` end to end, what it refuses: path traversal (raw request targets, sent byte for
//! byte), oversized request heads, too many connections, slow clients; and graceful shutdown.

mod common;

use common::{Http, parse, raw, request, site, start};
use kloub_server::serve::{Limits, MemoryDir, ServeConfig, Source};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// Request targets that must never reach `secret.txt` (beside the roots), a dot-file, or
/// anything outside the roots. Sent verbatim.
const TRAVERSAL: [&str; 44] = [
    "/../secret.txt",
    "/assets/../secret.txt",
    "/assets/../../secret.txt",
    "/assets/sub/../../secret.txt",
    "/%2e%2e/secret.txt",
    "/%2E%2E/secret.txt",
    "/.%2e/secret.txt",
    "/assets/%2e%2e/%2e%2e/secret.txt",
    "/..%2fsecret.txt",
    "/..%2Fsecret.txt",
    "/assets/..%2fsecret.txt",
    "/assets/%2e%2e%2fsecret.txt",
    "/assets/..%2f..%2fsecret.txt",
    "/assets/..%5csecret.txt",
    "/assets/..%5C..%5Csecret.txt",
    "/assets/..\\secret.txt",
    "/assets\\..\\secret.txt",
    "/%5c..%5csecret.txt",
    "/%252e%252e/secret.txt",
    "/assets/%252e%252e%252fsecret.txt",
    "/%25%32%65%25%32%65/secret.txt",
    "/%c0%ae%c0%ae/secret.txt",
    "/%e0%80%ae%e0%80%ae/secret.txt",
    "/c:/secret.txt",
    "/C:%5Csecret.txt",
    "/C%3A%5Csecret.txt",
    "/assets/c:/windows/win.ini",
    "/assets/Fox.glb::$DATA",
    "/secret.txt%00.html",
    "/index.html%00",
    "/assets/Fox.glb%00.txt",
    "/.wasm-opt-input",
    "/assets/.hidden",
    "/assets/link-out.txt",
    "/up/secret.txt",
    "/up/assets/Fox.glb",
    "/CON",
    "/assets/nul.glb",
    "/aux",
    "/assets/com1.glb",
    "/lpt1.txt",
    "/assets/Fox.glb.",
    "/%",
    "//secret.txt",
];

/// Targets that are simply not files: 404 too, and never echoed.
const NOT_FILES: [&str; 5] = ["/assets/", "/sub", "/missing.html", "/models/other.glb", "/assets/sub"];

#[test]
fn traversal_vectors_are_refused_without_echo() {
    let site = site("safety-traversal");
    std::fs::write(site.assets.join(".hidden"), "hidden").expect("write");
    for (mode, config) in [("disk", site.disk_config()), ("memory", site.memory_config())] {
        let server = start(&config);
        for v in TRAVERSAL.iter().chain(&NOT_FILES) {
            let reply = request(server.addr, "GET", v, &[]);
            // hyper itself answers 400 to targets that are not valid HTTP (`\`, raw `%`
            // sequences it cannot parse): also a refusal, without a body.
            assert!(reply.status == 404 || reply.status == 400, "{mode} {v}: {reply:?}");
            if reply.status == 404 {
                assert_eq!(reply.header("x-content-type-options"), Some("nosniff"), "{v}");
                assert_eq!(reply.text(), "not found\n", "{mode} {v}: a fixed body, no echo");
            }
            let text = reply.text();
            assert!(!text.contains("secret") && !text.contains("hidden"), "{mode} {v}: {text}");
        }
        server.stop();
    }
    // The symlink out of the root is a real file behind a path that looks fine.
    assert!(site.assets.join("link-out.txt").is_file());
}

#[test]
fn traversal_with_a_well_behaved_client_too() {
    let site = site("safety-client");
    let server = start(&site.disk_config());
    let http = Http::new(server.addr);
    for v in TRAVERSAL.iter().filter(|v| !v.contains('\\') && !v.ends_with('%')) {
        let reply = http.get(v, &[]);
        assert_eq!(reply.status, 404, "{v}: {reply:?}");
        assert!(!reply.text().contains("secret"));
    }
}

#[test]
fn oversized_request_heads_get_431() {
    let site = site("safety-431");
    let server = start(&site.disk_config());
    let big =
        format!("GET / HTTP/1.1\r\nHost: x\r\nX-Big: {}\r\n\r\n", "a".repeat(Limits::default().max_header_bytes + 1));
    let reply = parse(&raw(server.addr, big.as_bytes()), false);
    assert_eq!(reply.status, 431);
    let mut many = String::from("GET / HTTP/1.1\r\nHost: x\r\n");
    for i in 0..150 {
        many.push_str(&format!("X-{i}: y\r\n"));
    }
    many.push_str("\r\n");
    assert_eq!(parse(&raw(server.addr, many.as_bytes()), false).status, 431);
    // A head just under the limit is fine.
    let fine = format!("GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\nX-Big: {}\r\n\r\n", "a".repeat(8000));
    assert_eq!(parse(&raw(server.addr, fine.as_bytes()), false).status, 200);
}

fn limited(limits: Limits) -> ServeConfig {
    let big = vec![7u8; 64 * 1024 * 1024];
    ServeConfig {
        dist: Source::Memory(MemoryDir::new([
            ("index.html".to_owned(), bytes::Bytes::from_static(b"<p>hi</p>")),
            ("big.bin".to_owned(), bytes::Bytes::from(big)),
        ])),
        assets: Source::Memory(MemoryDir::default()),
        limits,
        connect_src: None,
    }
}

#[test]
fn connections_over_the_limit_wait_for_a_free_slot() {
    let server = start(&limited(Limits { max_connections: 2, ..Limits::default() }));
    // Two idle connections take both slots.
    let first = TcpStream::connect(server.addr).expect("connect");
    let second = TcpStream::connect(server.addr).expect("connect");
    std::thread::sleep(Duration::from_millis(200));
    let mut third = TcpStream::connect(server.addr).expect("the kernel still accepts");
    third.write_all(b"GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").expect("send");
    third.set_read_timeout(Some(Duration::from_millis(700))).expect("timeout");
    let mut buf = [0u8; 64];
    let waited = third.read(&mut buf);
    assert!(waited.is_err(), "the third connection was served while two held the slots: {waited:?}");
    drop(first);
    third.set_read_timeout(Some(Duration::from_secs(10))).expect("timeout");
    let mut out = Vec::new();
    third.read_to_end(&mut out).expect("served once a slot is free");
    let reply = parse(&out, false);
    assert_eq!((reply.status, reply.body.as_slice()), (200, b"<p>hi</p>".as_slice()));
    drop(second);
}

#[test]
fn idle_and_slow_clients_are_cut_off() {
    let server = start(&limited(Limits {
        header_timeout: Duration::from_millis(500),
        send_timeout: Duration::from_millis(500),
        ..Limits::default()
    }));
    // A request head that never ends.
    let mut slow = TcpStream::connect(server.addr).expect("connect");
    slow.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n").expect("send");
    slow.set_read_timeout(Some(Duration::from_secs(10))).expect("timeout");
    let started = Instant::now();
    let mut out = Vec::new();
    let _ = slow.read_to_end(&mut out);
    assert!(started.elapsed() < Duration::from_secs(5), "closed after the head timeout");

    // A client that asks for 64 MiB and does not read: the server gives up on it.
    let mut stuck = TcpStream::connect(server.addr).expect("connect");
    stuck.write_all(b"GET /big.bin HTTP/1.1\r\nHost: x\r\n\r\n").expect("send");
    std::thread::sleep(Duration::from_secs(3));
    stuck.set_read_timeout(Some(Duration::from_secs(10))).expect("timeout");
    let mut received = 0usize;
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match stuck.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => received += n,
        }
    }
    assert!(received < 64 * 1024 * 1024, "the whole body arrived ({received} bytes): the stalled send was not cut");
    // The server still serves others.
    assert_eq!(request(server.addr, "GET", "/", &[]).status, 200);
}

#[test]
fn shutdown_finishes_requests_in_flight_then_refuses() {
    let server = start(&limited(Limits::default()));
    let addr = server.addr;
    let mut client = TcpStream::connect(addr).expect("connect");
    client.write_all(b"GET /big.bin HTTP/1.1\r\nHost: x\r\n\r\n").expect("send");
    let mut first = [0u8; 1024];
    client.read_exact(&mut first).expect("the response has started");
    let stopper = std::thread::spawn(move || server.stop());
    std::thread::sleep(Duration::from_millis(200));
    let mut rest = Vec::new();
    client.read_to_end(&mut rest).expect("the response completes");
    let mut whole = first.to_vec();
    whole.extend_from_slice(&rest);
    let reply = parse(&whole, false);
    assert_eq!(reply.status, 200);
    assert_eq!(reply.body.len(), 64 * 1024 * 1024, "the request in flight finished");
    stopper.join().expect("the server stopped");
    assert!(TcpStream::connect(addr).is_err(), "no longer listening");
}
