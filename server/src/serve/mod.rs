//! `kloub serve`: the web bundle, the default model and the sample library over HTTP/1.1.
//!
//! Routes (GET and HEAD; OPTIONS preflights on the library routes):
//! - `/`, `/index.html` → the bundle's `index.html`; without one, a 500 page says how to build it;
//! - `/models/default.glb` → `Fox.glb` of the library (CORS);
//! - `/api/assets` → JSON index of the library's models ([`index`]), built once at start-up (CORS);
//! - `/assets/<path>` → files of the library (CORS);
//! - any other path → files of the bundle.
//!
//! The bundle and the library each come from a folder on disk or from memory: by default the
//! copies embedded in the binary at build time ([`embedded`]), so the binary alone is a deploy.
//!
//! Every file answer follows [`respond`]: exact `Content-Type` ([`mime`]), precompressed
//! `.br`/`.gz` siblings chosen by `Accept-Encoding`, strong ETags and 304, single byte ranges,
//! HEAD, `Cache-Control` (`no-cache` + ETag, or a year and `immutable` for content-hashed
//! names). Every response carries `X-Content-Type-Options: nosniff`; HTML carries [`CSP`];
//! library routes carry `Access-Control-Allow-Origin: *` so other sites can embed the viewer
//! with our samples. Refusals: a request with a body is 413, any other method 405 with `Allow`,
//! a path the policy of [`crate::paths`] refuses (traversal, odd names, symlinks out of the root)
//! is a 404 that never echoes the path. Limits ([`Limits`]): connections, request head size
//! (431), timeouts. One `access` log line per request ([`crate::logger`]).

pub mod embedded;
pub mod files;
pub mod index;
pub mod listen;
pub mod mime;
pub mod respond;

pub use files::{MemoryDir, Source};
pub use listen::Limits;

use crate::logger;
use crate::paths::Refusal;
use bytes::Bytes;
use files::{Content, Root};
use http_body_util::combinators::UnsyncBoxBody;
use http_body_util::{BodyExt, Empty, Full};
use hyper::body::{Body as _, Frame};
use hyper::header::{
    ALLOW, CONNECTION, CONTENT_LENGTH, CONTENT_SECURITY_POLICY, CONTENT_TYPE, HeaderMap, HeaderName, HeaderValue,
    TRANSFER_ENCODING, X_CONTENT_TYPE_OPTIONS,
};
use hyper::{Method, Request, Response, StatusCode};
use std::fmt::Write as _;
use std::io::{self, Read, Seek, SeekFrom};
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Instant;
use tokio::io::AsyncReadExt;
use tokio_util::io::ReaderStream;

/// File served at `/models/default.glb`, relative to the library.
pub const DEFAULT_MODEL: &str = "Fox.glb";

/// The README's run command, named on the page shown when the bundle is not built.
pub const RUN_COMMAND: &str = "./scripts/run.sh";

/// Where the page may fetch models from besides its own server (`connect-src`), unless
/// `kloub serve --connect-src` says otherwise: any `https:` origin (CDNs, buckets) and `http:`
/// on loopback (a colleague's `kloub serve`, a local static server).
pub const DEFAULT_CONNECT_SRC: &str = "https: http://127.0.0.1:* http://localhost:*";

/// `Content-Security-Policy` of HTML responses with [`DEFAULT_CONNECT_SRC`]: only our own
/// scripts, WebAssembly compilation allowed (`'wasm-unsafe-eval'`) but no JavaScript `eval`;
/// inline styles allowed (egui sets element styles); models fetched from the page's server and
/// the default other origins; embeddable in any page (`frame-ancestors *`).
pub const CSP: &str = "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; \
    style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; \
    connect-src 'self' blob: data: https: http://127.0.0.1:* http://localhost:*; \
    worker-src 'self' blob:; object-src 'none'; base-uri 'none'; frame-ancestors *";

/// [`CSP`] with `connect-src 'self' blob: data:` plus `sources` (space-separated CSP source
/// expressions, e.g. `https://cdn.example.com`; empty: the page's own server only).
///
/// # Errors
/// A source with a character outside CSP's source grammar (`;`, `,`, quotes…), which could
/// otherwise smuggle in another directive, or a control character (newline, tab) between them.
pub fn csp(sources: &str) -> Result<String, String> {
    if sources.chars().any(char::is_control) {
        return Err("connect-src: sources are separated by spaces; control characters are not allowed".to_owned());
    }
    for token in sources.split_whitespace() {
        let ok = token.chars().all(|c| c.is_ascii_alphanumeric() || "*:/.-_+[]%~".contains(c));
        if !ok {
            return Err(format!("connect-src source {token:?}: only URL characters are allowed"));
        }
    }
    let list: Vec<&str> = sources.split_whitespace().collect();
    let connect = if list.is_empty() { String::new() } else { format!(" {}", list.join(" ")) };
    Ok(CSP.replacen(
        &format!("connect-src 'self' blob: data: {DEFAULT_CONNECT_SRC};"),
        &format!("connect-src 'self' blob: data:{connect};"),
        1,
    ))
}

/// Methods of the bundle routes, for `Allow`.
const ALLOW_BUNDLE: &str = "GET, HEAD";
/// Methods of the library routes (CORS preflight included), for `Allow`.
const ALLOW_LIBRARY: &str = "GET, HEAD, OPTIONS";
/// Disk reads up to this size are done in one go; larger ones are streamed.
const SMALL_READ: u64 = 1 << 20;
/// Longest request path written to the log.
const MAX_LOGGED_PATH: usize = 256;

/// Response body of every answer.
pub type Body = UnsyncBoxBody<Bytes, io::Error>;

/// What `kloub serve` serves, and its limits.
#[derive(Clone, Debug)]
pub struct ServeConfig {
    /// The web bundle (`index.html`, `kloub_web.js`, `kloub_web_bg.wasm`, ...).
    pub dist: Source,
    /// The sample library (`Fox.glb` and friends).
    pub assets: Source,
    /// Resource limits.
    pub limits: Limits,
    /// The origins the page may fetch models from besides its own server (see [`csp`]);
    /// `None`: [`DEFAULT_CONNECT_SRC`].
    pub connect_src: Option<String>,
}

impl Default for ServeConfig {
    /// The bundle and the samples embedded in the binary, default limits and origins.
    fn default() -> Self {
        Self {
            dist: Source::Memory(embedded::dist()),
            assets: Source::Memory(embedded::assets()),
            limits: Limits::default(),
            connect_src: None,
        }
    }
}

/// The application: routes, file answers, headers, log. Read-only once built.
pub struct App {
    dist: Root,
    assets: Root,
    /// The `/api/assets` body, as a one-file root so it gets ETags, HEAD and ranges too.
    index: Root,
    limits: Limits,
    /// The `Content-Security-Policy` of HTML answers.
    csp: HeaderValue,
}

impl App {
    /// Opens the sources and builds the library index (imports every model: blocking,
    /// call it before serving). Missing folders are logged, not fatal: the bundle page then
    /// explains how to build it and the library routes answer 404.
    pub fn new(config: &ServeConfig) -> Self {
        let dist = Root::open(&config.dist, "web bundle (--dist)");
        let assets = Root::open(&config.assets, "sample library (--assets)");
        if !dist.has("index.html") {
            log::warn!("the web bundle has no index.html: run `{RUN_COMMAND}`");
        }
        let started = Instant::now();
        let entries = index::build(&assets);
        log::info!(
            "asset index: {} model(s), {} with errors, built in {} ms",
            entries.len(),
            entries.iter().filter(|e| e.error.is_some()).count(),
            started.elapsed().as_millis()
        );
        let json = serde_json::to_vec(&entries).unwrap_or_else(|_| b"[]".to_vec());
        let index = Root::Memory(MemoryDir::new([("assets.json".to_owned(), Bytes::from(json))]));
        let policy = config.connect_src.as_deref().map_or_else(|| Ok(CSP.to_owned()), csp);
        // An invalid list fails closed: this server's own models only.
        let own_only = || csp("").ok().and_then(|p| HeaderValue::from_str(&p).ok());
        let csp = policy.ok().and_then(|p| HeaderValue::from_str(&p).ok()).or_else(|| {
            log::error!("--connect-src is not a list of CSP sources: only this server's models can be opened");
            own_only()
        });
        let csp = csp.unwrap_or_else(|| HeaderValue::from_static(CSP));
        Self { dist, assets, index, limits: config.limits, csp }
    }

    /// Answers one request (the body is never read: requests with one are refused).
    pub async fn handle<B>(&self, req: Request<B>) -> Response<Body> {
        let started = Instant::now();
        let path = req.uri().path();
        let library = is_library(path);
        let mut res = match tokio::time::timeout(self.limits.handler_timeout, self.route(&req)).await {
            Ok(r) => r,
            Err(_) => text(StatusCode::SERVICE_UNAVAILABLE, "timed out\n"),
        };
        let headers = res.headers_mut();
        headers.insert(X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
        let html = headers.get(CONTENT_TYPE).is_some_and(|t| t.as_bytes().starts_with(b"text/html"));
        if html {
            headers.insert(CONTENT_SECURITY_POLICY, self.csp.clone());
        }
        if library {
            cors(headers);
        }
        log_access(req.method(), path, &res, started);
        res
    }

    async fn route<B>(&self, req: &Request<B>) -> Response<Body> {
        let method = req.method();
        let path = req.uri().path();
        let library = is_library(path);
        if has_body(req.headers()) {
            let mut res = text(StatusCode::PAYLOAD_TOO_LARGE, "request bodies are not accepted\n");
            res.headers_mut().insert(CONNECTION, HeaderValue::from_static("close"));
            return res;
        }
        if method == Method::OPTIONS && library {
            return preflight();
        }
        if method != Method::GET && method != Method::HEAD {
            let mut res = text(StatusCode::METHOD_NOT_ALLOWED, "method not allowed\n");
            let allow = if library { ALLOW_LIBRARY } else { ALLOW_BUNDLE };
            res.headers_mut().insert(ALLOW, HeaderValue::from_static(allow));
            return res;
        }
        let headers = req.headers();
        match path {
            "/" | "/index.html" if !self.dist.has("index.html") => not_built(),
            "/" | "/index.html" => serve_file(&self.dist, "index.html", method, headers).await,
            "/api/assets" => serve_file(&self.index, "assets.json", method, headers).await,
            "/models/default.glb" => serve_file(&self.assets, DEFAULT_MODEL, method, headers).await,
            _ => match path.strip_prefix("/assets/") {
                Some(rel) => serve_file(&self.assets, rel, method, headers).await,
                None if path.starts_with("/models/") => not_found(),
                None => serve_file(&self.dist, path, method, headers).await,
            },
        }
    }
}

/// Library routes: CORS `*`, OPTIONS preflights.
fn is_library(path: &str) -> bool {
    path == "/api/assets" || path.starts_with("/assets/") || path.starts_with("/models/")
}

/// A request carries a body: `Content-Length` other than 0, or any `Transfer-Encoding`.
fn has_body(headers: &HeaderMap) -> bool {
    headers.contains_key(TRANSFER_ENCODING) || headers.get_all(CONTENT_LENGTH).iter().any(|v| v.as_bytes() != b"0")
}

fn cors(headers: &mut HeaderMap) {
    let set = |h: &mut HeaderMap, name: &'static str, value: &'static str| {
        h.insert(HeaderName::from_static(name), HeaderValue::from_static(value));
    };
    set(headers, "access-control-allow-origin", "*");
    set(headers, "access-control-expose-headers", "ETag, Content-Range, Accept-Ranges, Content-Encoding");
    set(headers, "cross-origin-resource-policy", "cross-origin");
}

fn preflight() -> Response<Body> {
    let mut res = Response::new(empty());
    *res.status_mut() = StatusCode::NO_CONTENT;
    let h = res.headers_mut();
    h.insert(ALLOW, HeaderValue::from_static(ALLOW_LIBRARY));
    for (name, value) in [
        ("access-control-allow-methods", "GET, HEAD"),
        ("access-control-allow-headers", "*"),
        ("access-control-max-age", "86400"),
    ] {
        h.insert(HeaderName::from_static(name), HeaderValue::from_static(value));
    }
    res
}

/// Why a file answer failed.
enum Failure {
    /// Refused or missing: 404 either way.
    NotFound,
    /// The file exists but could not be read.
    Io(io::Error),
}

/// The bytes of a planned answer.
enum Payload {
    Empty,
    Bytes(Bytes),
    /// An open file positioned at the range start, and the range length.
    Stream(std::fs::File, u64),
}

/// Serves the file at percent-encoded relative path `rel` of `root` ([`respond::plan`]).
async fn serve_file(root: &Root, rel: &str, method: &Method, headers: &HeaderMap) -> Response<Body> {
    let prepared = match root {
        // Disk look-ups and small reads block: one trip to the blocking pool per request.
        Root::Dir(_) => {
            let (root, rel, method, headers) = (root.clone(), rel.to_owned(), method.clone(), headers.clone());
            tokio::task::spawn_blocking(move || prepare(&root, &rel, &method, &headers))
                .await
                .unwrap_or_else(|e| Err(Failure::Io(io::Error::other(e))))
        }
        _ => prepare(root, rel, method, headers),
    };
    match prepared {
        Ok((status, headers, payload)) => {
            let body = match payload {
                Payload::Empty => empty(),
                Payload::Bytes(b) => full(b),
                Payload::Stream(file, len) => FileBody::new(file, len).boxed_unsync(),
            };
            let mut res = Response::new(body);
            *res.status_mut() = status;
            *res.headers_mut() = headers;
            res
        }
        Err(Failure::NotFound) => not_found(),
        Err(Failure::Io(e)) => {
            log::error!("cannot read a file: {e}");
            text(StatusCode::INTERNAL_SERVER_ERROR, "cannot read the file\n")
        }
    }
}

fn prepare(
    root: &Root,
    rel: &str,
    method: &Method,
    headers: &HeaderMap,
) -> Result<(StatusCode, HeaderMap, Payload), Failure> {
    let found = root.lookup(rel).map_err(|r| {
        if r == Refusal::Unsafe {
            log::warn!("refused an unsafe path");
        }
        Failure::NotFound
    })?;
    let plan = respond::plan(method, headers, &found);
    let payload = match plan.body {
        None => Payload::Empty,
        Some((Content::Memory(bytes), range)) => {
            // Ranges are within the length the plan was made for, which is this length.
            let (start, end) = (range.start as usize, range.end as usize);
            Payload::Bytes(bytes.slice(start..end.min(bytes.len())))
        }
        Some((Content::Disk(path), range)) => {
            let len = range.end - range.start;
            let mut file = std::fs::File::open(&path).map_err(|e| match e.kind() {
                io::ErrorKind::NotFound => Failure::NotFound,
                _ => Failure::Io(e),
            })?;
            file.seek(SeekFrom::Start(range.start)).map_err(Failure::Io)?;
            if len <= SMALL_READ {
                let mut buf = Vec::with_capacity(len as usize);
                file.take(len).read_to_end(&mut buf).map_err(Failure::Io)?;
                if buf.len() as u64 != len {
                    return Err(Failure::Io(io::Error::other("the file shrank while read")));
                }
                Payload::Bytes(Bytes::from(buf))
            } else {
                Payload::Stream(file, len)
            }
        }
    };
    Ok((plan.status, plan.headers, payload))
}

/// A file range streamed in 64 KiB chunks.
struct FileBody {
    stream: ReaderStream<tokio::io::Take<tokio::fs::File>>,
    left: u64,
}

impl FileBody {
    fn new(file: std::fs::File, len: u64) -> Self {
        let file = tokio::fs::File::from_std(file).take(len);
        Self { stream: ReaderStream::with_capacity(file, 64 * 1024), left: len }
    }
}

impl hyper::body::Body for FileBody {
    type Data = Bytes;
    type Error = io::Error;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, io::Error>>> {
        use futures_core::Stream;
        match Pin::new(&mut self.stream).poll_next(cx) {
            Poll::Ready(Some(Ok(chunk))) => {
                self.left = self.left.saturating_sub(chunk.len() as u64);
                Poll::Ready(Some(Ok(Frame::data(chunk))))
            }
            // Fewer bytes than announced: fail, so hyper closes instead of hanging.
            Poll::Ready(None) if self.left > 0 => {
                Poll::Ready(Some(Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the file shrank while sent"))))
            }
            other => other.map(|o| o.map(|r| r.map(Frame::data))),
        }
    }

    fn size_hint(&self) -> hyper::body::SizeHint {
        hyper::body::SizeHint::with_exact(self.left)
    }
}

fn full(bytes: Bytes) -> Body {
    Full::new(bytes).map_err(|never| match never {}).boxed_unsync()
}

fn empty() -> Body {
    Empty::new().map_err(|never| match never {}).boxed_unsync()
}

fn text(status: StatusCode, body: &'static str) -> Response<Body> {
    let mut res = Response::new(full(Bytes::from_static(body.as_bytes())));
    *res.status_mut() = status;
    res.headers_mut().insert(CONTENT_TYPE, HeaderValue::from_static("text/plain; charset=utf-8"));
    res
}

/// The 404 answer; it never names the path.
fn not_found() -> Response<Body> {
    text(StatusCode::NOT_FOUND, "not found\n")
}

fn not_built() -> Response<Body> {
    let body = format!(
        "<!doctype html>\n<meta charset=\"utf-8\">\n<title>kloub: web bundle not built</title>\n\
         <h1>web bundle not built: run <code>{RUN_COMMAND}</code></h1>\n\
         <p><code>kloub serve</code> has no <code>index.html</code>: the binary was built before \
         the web bundle and no <code>--dist</code> folder with one was given.</p>\n"
    );
    let mut res = Response::new(full(Bytes::from(body)));
    *res.status_mut() = StatusCode::INTERNAL_SERVER_ERROR;
    let h = res.headers_mut();
    h.insert(CONTENT_TYPE, HeaderValue::from_static("text/html; charset=utf-8"));
    h.insert(hyper::header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    res
}

/// One `access` line: method, path (quoted, cut), status, body bytes, duration.
fn log_access(method: &Method, path: &str, res: &Response<Body>, started: Instant) {
    if !log::log_enabled!(target: logger::ACCESS, log::Level::Info) {
        return;
    }
    let bytes = if method == Method::HEAD { 0 } else { res.body().size_hint().exact().unwrap_or(0) };
    let mut shown = path;
    if shown.len() > MAX_LOGGED_PATH {
        let mut end = MAX_LOGGED_PATH;
        while !shown.is_char_boundary(end) {
            end -= 1;
        }
        shown = &shown[..end];
    }
    let mut line = format!("method={method} path=");
    logger::quote_into(&mut line, shown);
    let _ =
        write!(line, " status={} bytes={bytes} ms={:.3}", res.status().as_u16(), started.elapsed().as_secs_f64() * 1e3);
    log::info!(target: logger::ACCESS, "{line}");
}

/// Binds `addr`, prints `kloub serve: listening on http://ADDR` and serves `app` until
/// SIGINT or SIGTERM, then shuts down gracefully ([`listen::run`]).
pub async fn serve(app: App, addr: SocketAddr) -> io::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr).await?;
    println!("kloub serve: listening on http://{}", listener.local_addr()?);
    listen::run(listener, Arc::new(app), shutdown_signal()).await
}

async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            log::error!("cannot listen for Ctrl-C: {e}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                log::error!("cannot listen for SIGTERM: {e}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {}
        () = term => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn body_detection() {
        let h = |pairs: &[(&'static str, &'static str)]| {
            let mut m = HeaderMap::new();
            for (n, v) in pairs {
                m.append(HeaderName::from_static(n), HeaderValue::from_static(v));
            }
            m
        };
        assert!(!has_body(&h(&[])));
        assert!(!has_body(&h(&[("content-length", "0")])));
        assert!(has_body(&h(&[("content-length", "1")])));
        assert!(has_body(&h(&[("transfer-encoding", "chunked")])));
    }

    #[test]
    fn library_routes() {
        for p in ["/api/assets", "/assets/Fox.glb", "/models/default.glb", "/models/x"] {
            assert!(is_library(p), "{p}");
        }
        for p in ["/", "/index.html", "/kloub_web.js", "/api/assets/x", "/assets", "/api"] {
            assert!(!is_library(p), "{p}");
        }
    }

    #[test]
    fn csp_allows_wasm_but_not_eval() {
        assert!(CSP.contains("'wasm-unsafe-eval'"));
        assert!(!CSP.contains("'unsafe-eval'"));
        assert!(CSP.contains("frame-ancestors *"));
    }

    #[test]
    fn connect_src_is_the_default_origins_or_what_the_deployment_lists() {
        assert!(CSP.contains(&format!("connect-src 'self' blob: data: {DEFAULT_CONNECT_SRC};")));
        assert_eq!(csp(DEFAULT_CONNECT_SRC).as_deref(), Ok(CSP));
        let narrow = csp("https://cdn.example.com  https://*.bucket.example:443").unwrap_or_default();
        assert!(
            narrow.contains("connect-src 'self' blob: data: https://cdn.example.com https://*.bucket.example:443;")
        );
        assert!(!narrow.contains("http://127.0.0.1"));
        assert!(csp("").is_ok_and(|p| p.contains("connect-src 'self' blob: data:;")));
        for bad in ["https://a; script-src *", "'unsafe-eval'", "a,b", "x\ny"] {
            assert!(csp(bad).is_err(), "{bad:?}");
        }
    }
}
