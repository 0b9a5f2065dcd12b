//! Helpers of the server's integration tests: the real server on 127.0.0.1:0 in a background
//! thread, a real HTTP client (hyper's), a raw HTTP/1.1 client over `TcpStream` for request
//! targets no well-behaved client would send, and fresh temporary folders.

#![allow(dead_code)]

use bytes::Bytes;
use http_body_util::{BodyExt, Full};
use hyper_util::client::legacy::Client;
use hyper_util::client::legacy::connect::HttpConnector;
use hyper_util::rt::TokioExecutor;
use kloub_server::serve::{App, ServeConfig, listen};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// A parsed HTTP response.
#[derive(Debug)]
pub struct Reply {
    pub status: u16,
    /// Header names lower-cased, in order.
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Reply {
    /// The value of a header (case-insensitive name), if present.
    pub fn header(&self, name: &str) -> Option<&str> {
        let name = name.to_ascii_lowercase();
        self.headers.iter().find(|(n, _)| *n == name).map(|(_, v)| v.as_str())
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

/// The real server (`App` + `listen::run`) on an ephemeral port; stopped gracefully on drop.
pub struct Server {
    pub addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Triggers the graceful shutdown and waits until the server loop has returned.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            thread.join().expect("the server thread ends cleanly");
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Starts `config` on 127.0.0.1:0.
pub fn start(config: &ServeConfig) -> Server {
    let app = Arc::new(App::new(config));
    let (addr_tx, addr_rx) = std::sync::mpsc::channel();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let thread = std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .expect("a tokio runtime");
        runtime.block_on(async move {
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
            addr_tx.send(listener.local_addr().expect("local address")).expect("report the address");
            listen::run(listener, app, async {
                let _ = stopped.await;
            })
            .await
            .expect("serve");
        });
    });
    Server { addr: addr_rx.recv().expect("the server started"), stop: Some(stop), thread: Some(thread) }
}

/// hyper's client on a runtime of its own.
pub struct Http {
    runtime: tokio::runtime::Runtime,
    client: Client<HttpConnector, Full<Bytes>>,
    addr: SocketAddr,
}

impl Http {
    pub fn new(addr: SocketAddr) -> Self {
        let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("a tokio runtime");
        let client = Client::builder(TokioExecutor::new()).build_http();
        Self { runtime, client, addr }
    }

    /// GET `target` with extra headers.
    pub fn get(&self, target: &str, headers: &[(&str, &str)]) -> Reply {
        self.send("GET", target, headers, None)
    }

    /// Sends one request and reads the whole response.
    pub fn send(&self, method: &str, target: &str, headers: &[(&str, &str)], body: Option<&[u8]>) -> Reply {
        let mut request = hyper::Request::builder().method(method).uri(format!("http://{}{target}", self.addr));
        for (n, v) in headers {
            request = request.header(*n, *v);
        }
        let body = Full::new(Bytes::copy_from_slice(body.unwrap_or_default()));
        let request = request.body(body).expect("a valid request");
        self.runtime.block_on(async {
            let response = tokio::time::timeout(Duration::from_secs(20), self.client.request(request))
                .await
                .expect("an answer within 20 s")
                .expect("an HTTP response");
            let status = response.status().as_u16();
            let headers = response
                .headers()
                .iter()
                .map(|(n, v)| (n.as_str().to_owned(), v.to_str().expect("ASCII header").to_owned()))
                .collect();
            let body = response.into_body().collect().await.expect("the whole body").to_bytes().to_vec();
            Reply { status, headers, body }
        })
    }
}

/// Sends `raw` bytes as they are and reads until the server closes (or 10 s pass).
pub fn raw(addr: SocketAddr, raw: &[u8]) -> Vec<u8> {
    let mut stream = TcpStream::connect(addr).expect("connect to the test server");
    stream.set_read_timeout(Some(Duration::from_secs(10))).expect("timeout");
    stream.write_all(raw).expect("send the request");
    let mut out = Vec::new();
    // A reset after the answer (the server closing on unread input) still leaves the answer.
    let _ = stream.read_to_end(&mut out);
    out
}

/// Sends one request with `Connection: close` and reads the whole response.
/// `target` is written verbatim (no normalization), so traversal vectors reach the server as is.
pub fn request(addr: SocketAddr, method: &str, target: &str, extra: &[(&str, &str)]) -> Reply {
    let mut head = format!("{method} {target} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n");
    for (name, value) in extra {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str("\r\n");
    parse(&raw(addr, head.as_bytes()), method == "HEAD")
}

/// Parses one HTTP/1.1 response (identity or chunked body).
pub fn parse(raw: &[u8], head_only: bool) -> Reply {
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no header block in {:?}", String::from_utf8_lossy(raw)));
    let head = std::str::from_utf8(&raw[..split]).expect("ASCII headers");
    let mut lines = head.split("\r\n");
    let status_line = lines.next().expect("a status line");
    let status = status_line.split(' ').nth(1).expect("a status code").parse().expect("numeric");
    let headers: Vec<(String, String)> = lines
        .map(|l| {
            let (n, v) = l.split_once(':').expect("name: value");
            (n.trim().to_ascii_lowercase(), v.trim().to_owned())
        })
        .collect();
    let rest = &raw[split + 4..];
    let chunked = headers.iter().any(|(n, v)| n == "transfer-encoding" && v.contains("chunked"));
    let body = if head_only {
        rest.to_vec()
    } else if chunked {
        dechunk(rest)
    } else {
        rest.to_vec()
    };
    Reply { status, headers, body }
}

fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let end = data.windows(2).position(|w| w == b"\r\n").expect("chunk size line");
        let size_text = std::str::from_utf8(&data[..end]).expect("ASCII");
        let size =
            usize::from_str_radix(size_text.split(';').next().expect("size").trim(), 16).expect("hex chunk size");
        data = &data[end + 2..];
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&data[..size]);
        data = &data[size + 2..];
    }
}

/// A fresh, empty temporary folder unique to this test.
pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kloub-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir is writable");
    dir
}

/// The repository root (this crate's parent folder).
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("the server crate is in the repository").to_path_buf()
}

/// `tests/assets` in the repository, overridable with `KLOUB_SHARED_ASSETS`.
pub fn shared_assets() -> PathBuf {
    std::env::var_os("KLOUB_SHARED_ASSETS").map(PathBuf::from).unwrap_or_else(|| repo().join("tests/assets"))
}

/// A test site: a bundle folder, a library folder, and a secret beside them.
pub struct Site {
    pub base: PathBuf,
    pub dist: PathBuf,
    pub assets: PathBuf,
}

impl Site {
    /// Serves both folders from disk (`--dist`, `--assets`).
    pub fn disk_config(&self) -> kloub_server::serve::ServeConfig {
        kloub_server::serve::ServeConfig {
            dist: kloub_server::serve::Source::Dir(self.dist.clone()),
            assets: kloub_server::serve::Source::Dir(self.assets.clone()),
            limits: Default::default(),
            connect_src: None,
        }
    }

    /// Serves the same files from memory, as the embedded bundle is served.
    pub fn memory_config(&self) -> kloub_server::serve::ServeConfig {
        kloub_server::serve::ServeConfig {
            dist: kloub_server::serve::Source::Memory(memory_of(&self.dist)),
            assets: kloub_server::serve::Source::Memory(memory_of(&self.assets)),
            limits: Default::default(),
            connect_src: None,
        }
    }

    pub fn read_dist(&self, name: &str) -> Vec<u8> {
        std::fs::read(self.dist.join(name)).expect("fixture exists")
    }
}

impl Drop for Site {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.base);
    }
}

/// Compressible, not repetitive bytes.
pub fn sample_bytes(len: usize, seed: u32) -> Vec<u8> {
    let mut x = seed.max(1);
    (0..len)
        .map(|i| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            if i % 4 == 0 { (x % 16) as u8 } else { b'a' + (x % 8) as u8 }
        })
        .collect()
}

pub fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(data).expect("in memory");
    e.finish().expect("in memory")
}

pub fn gunzip(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(data).read_to_end(&mut out).expect("valid gzip");
    out
}

pub fn unbrotli(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    brotli_decompressor::Decompressor::new(data, 4096).read_to_end(&mut out).expect("valid brotli");
    out
}

/// Size of the file streamed from disk in pieces (over the server's one-read limit).
pub const BIG_LEN: usize = 3 * 1024 * 1024 + 17;

/// Builds a site under a fresh temporary folder.
pub fn site(tag: &str) -> Site {
    let base = temp_dir(tag);
    let dist = base.join("dist");
    let assets = base.join("assets");
    std::fs::create_dir_all(&dist).expect("mkdir");
    std::fs::create_dir_all(assets.join("sub")).expect("mkdir");
    let write = |path: PathBuf, bytes: &[u8]| std::fs::write(path, bytes).expect("write");
    write(dist.join("index.html"), b"<!doctype html><title>kloub</title>");
    write(dist.join("kloub_web.js"), b"export default 1;");
    let wasm = sample_bytes(64 * 1024, 7);
    write(dist.join("kloub_web_bg.wasm"), &wasm);
    write(dist.join("kloub_web_bg.wasm.gz"), &gzip(&wasm));
    write(dist.join("kloub_web_bg.wasm.br"), b"brotli stand-in");
    write(dist.join("style.css"), b"body{}");
    write(dist.join("app.0123456789abcdef.js"), b"hashed");
    write(dist.join("big.bin"), &sample_bytes(BIG_LEN, 3));
    write(dist.join(".wasm-opt-input"), b"hash");
    let fox = std::fs::read(repo().join("web/assets/Fox.glb")).expect("the bundled Fox");
    write(assets.join("Fox.glb"), &fox);
    write(assets.join("Fox.LICENSE.md"), b"CC0 fox");
    write(assets.join("sub/Man.gltf"), b"{}");
    write(assets.join("sub/Man.bin"), &[0u8; 4]);
    write(base.join("secret.txt"), b"top secret");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(base.join("secret.txt"), assets.join("link-out.txt")).expect("symlink");
        std::os::unix::fs::symlink(&base, dist.join("up")).expect("symlink");
    }
    Site { base, dist, assets }
}

/// Every regular file under `dir` (symlinks not followed) as an in-memory set.
pub fn memory_of(dir: &std::path::Path) -> kloub_server::serve::MemoryDir {
    fn walk(root: &std::path::Path, dir: &std::path::Path, out: &mut Vec<(String, Bytes)>) {
        for entry in std::fs::read_dir(dir).expect("readable").flatten() {
            let path = entry.path();
            let kind = entry.file_type().expect("file type");
            if kind.is_dir() {
                walk(root, &path, out);
            } else if kind.is_file() {
                let rel = path.strip_prefix(root).expect("under root");
                let rel = rel.to_str().expect("UTF-8").replace('\\', "/");
                out.push((rel, Bytes::from(std::fs::read(&path).expect("read"))));
            }
        }
    }
    let mut files = Vec::new();
    walk(dir, dir, &mut files);
    kloub_server::serve::MemoryDir::new(files)
}
