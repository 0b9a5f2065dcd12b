//! `kloub serve`: the web bundle, the default model and the asset library over HTTP.
//!
//! Routes (GET and HEAD only; any other method is 405 with `Allow: GET, HEAD`):
//! - `/` → `<dist>/index.html`; when it is missing, a 500 page says how to build the bundle;
//! - `/models/default.glb` → `<assets>/Fox.glb`;
//! - `/api/assets` → JSON index of the `.glb`/`.gltf` files under `<assets>` ([`index`]), built once;
//! - `/assets/<path>` → files under `<assets>`;
//! - any other path → files under `<dist>`.
//!
//! Every response carries `X-Content-Type-Options: nosniff`; files get an exact
//! `Content-Type` ([`mime`]). Paths go through [`crate::paths`]: traversal, odd names and
//! symlinks out of the root give a 404 whose body never echoes the path.
//! [`router`] builds everything in-process, so tests can serve it on any listener.

pub mod index;
pub mod mime;

use crate::paths::{self, Refusal};
use axum::Router;
use axum::body::Body;
use axum::extract::{Request, State};
use axum::http::header::{ALLOW, CONTENT_TYPE, HeaderValue, X_CONTENT_TYPE_OPTIONS};
use axum::http::{Method, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tower_http::services::ServeFile;
use tower_http::set_header::SetResponseHeaderLayer;

/// File served at `/models/default.glb`, relative to the asset folder.
pub const DEFAULT_MODEL: &str = "Fox.glb";

/// The README's run command, named on the page shown when the bundle is not built.
pub const RUN_COMMAND: &str = "./scripts/run.sh";

/// Folders `kloub serve` serves from.
#[derive(Clone, Debug)]
pub struct ServeConfig {
    /// The built web bundle (`index.html`, `kloub_web.js`, `kloub_web_bg.wasm`, ...).
    pub dist: PathBuf,
    /// The model library (`Fox.glb` and friends).
    pub assets: PathBuf,
}

impl Default for ServeConfig {
    /// `web/dist` and `web/assets` of the repository ([`repo_dir`]).
    fn default() -> Self {
        Self {
            dist: repo_dir("web/dist"),
            assets: repo_dir("web/assets"),
        }
    }
}

/// A folder of the repository: `<current dir>/<rel>` when it exists (running from the
/// checkout root), else `<rel>` beside this crate's source folder as it was at compile time
/// (`CARGO_MANIFEST_DIR/..`), which works from any current directory on the build machine.
pub fn repo_dir(rel: &str) -> PathBuf {
    let here = Path::new(rel);
    if here.is_dir() {
        return here.to_path_buf();
    }
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().unwrap_or(manifest).join(rel)
}

/// Shared, read-only state of the router.
struct AppState {
    /// Canonical bundle folder; `None` when it does not exist.
    dist: Option<PathBuf>,
    /// Canonical asset folder; `None` when it does not exist.
    assets: Option<PathBuf>,
    /// Serialized `/api/assets` body.
    index_json: String,
}

/// Builds the whole application: routes, method filter, request log and `nosniff` header.
/// Scans the asset folder once, now. Missing folders are logged, not fatal: the bundle
/// page then explains how to build it and the asset routes answer 404.
pub fn router(config: &ServeConfig) -> Router {
    let dist = canonical_or_warn(&config.dist, "web bundle (--dist)");
    let assets = canonical_or_warn(&config.assets, "asset folder (--assets)");
    if let Some(d) = dist.as_deref().filter(|d| !d.join("index.html").is_file()) {
        log::warn!("{} has no index.html: run `{RUN_COMMAND}`", d.display());
    }
    let entries = assets.as_deref().map(index::scan).unwrap_or_default();
    log::info!("asset index: {} model(s)", entries.len());
    let index_json = serde_json::to_string(&entries).unwrap_or_else(|_| "[]".to_owned());
    let state = Arc::new(AppState {
        dist,
        assets,
        index_json,
    });

    Router::new()
        .route("/api/assets", get(api_assets))
        .route("/models/default.glb", get(default_model))
        .route("/assets/{*path}", get(asset_file))
        .fallback(bundle_file)
        .with_state(state)
        .layer(middleware::from_fn(only_get_and_head))
        .layer(middleware::from_fn(log_request))
        .layer(SetResponseHeaderLayer::overriding(
            X_CONTENT_TYPE_OPTIONS,
            HeaderValue::from_static("nosniff"),
        ))
}

/// Binds `addr`, prints `kloub serve: listening on http://ADDR` and serves until Ctrl-C
/// (or SIGTERM on Unix), letting requests in flight finish.
pub async fn serve(config: &ServeConfig, addr: SocketAddr) -> std::io::Result<()> {
    let app = router(config);
    let listener = tokio::net::TcpListener::bind(addr).await?;
    println!(
        "kloub serve: listening on http://{}",
        listener.local_addr()?
    );
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown_signal())
        .await?;
    log::info!("kloub serve: stopped");
    Ok(())
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
    log::info!("kloub serve: shutting down");
}

fn canonical_or_warn(dir: &Path, what: &str) -> Option<PathBuf> {
    match paths::canonical_root(dir) {
        Ok(c) if c.is_dir() => Some(c),
        _ => {
            log::warn!("{what} {} is not a folder", dir.display());
            None
        }
    }
}

async fn only_get_and_head(req: Request, next: Next) -> Response {
    if req.method() == Method::GET || req.method() == Method::HEAD {
        return next.run(req).await;
    }
    let mut res = (StatusCode::METHOD_NOT_ALLOWED, "method not allowed\n").into_response();
    res.headers_mut()
        .insert(ALLOW, HeaderValue::from_static("GET, HEAD"));
    res
}

async fn log_request(req: Request, next: Next) -> Response {
    let method = req.method().clone();
    let path = req.uri().path().to_owned();
    let start = std::time::Instant::now();
    let res = next.run(req).await;
    log::info!(
        "{method} {path} {} {:.1} ms",
        res.status().as_u16(),
        start.elapsed().as_secs_f64() * 1e3
    );
    res
}

async fn api_assets(State(state): State<Arc<AppState>>) -> Response {
    let mut res = state.index_json.clone().into_response();
    res.headers_mut()
        .insert(CONTENT_TYPE, HeaderValue::from_static("application/json"));
    res
}

async fn default_model(State(state): State<Arc<AppState>>, req: Request) -> Response {
    serve_under(state.assets.as_deref(), DEFAULT_MODEL, req).await
}

async fn asset_file(State(state): State<Arc<AppState>>, req: Request) -> Response {
    let rel = req
        .uri()
        .path()
        .strip_prefix("/assets/")
        .unwrap_or_default()
        .to_owned();
    serve_under(state.assets.as_deref(), &rel, req).await
}

async fn bundle_file(State(state): State<Arc<AppState>>, req: Request) -> Response {
    let path = req.uri().path();
    let rel = if path == "/" { "/index.html" } else { path }.to_owned();
    let index_missing = || {
        let dist = state.dist.as_deref();
        dist.is_none_or(|d| !d.join("index.html").is_file())
    };
    if rel == "/index.html" && index_missing() {
        return not_built();
    }
    serve_under(state.dist.as_deref(), &rel, req).await
}

/// Serves the file at the percent-encoded relative path `rel` under the canonical `root`,
/// with Range, HEAD and conditional requests, and an exact `Content-Type`.
async fn serve_under(root: Option<&Path>, rel: &str, req: Request) -> Response {
    let Some(root) = root else { return not_found() };
    let file = match paths::resolve_file(root, rel) {
        Ok(f) => f,
        Err(Refusal::Unsafe) => {
            log::warn!("refused an unsafe path");
            return not_found();
        }
        Err(Refusal::NotFound) => return not_found(),
    };
    let content_type = mime::content_type(&file);
    match ServeFile::new(&file).try_call(req).await {
        Ok(res) => {
            let mut res = res.map(Body::new);
            if res.headers().contains_key(CONTENT_TYPE) {
                res.headers_mut()
                    .insert(CONTENT_TYPE, HeaderValue::from_static(content_type));
            }
            res
        }
        Err(e) => {
            log::error!("cannot read {}: {e}", file.display());
            (StatusCode::INTERNAL_SERVER_ERROR, "cannot read the file\n").into_response()
        }
    }
}

fn not_found() -> Response {
    (StatusCode::NOT_FOUND, "not found\n").into_response()
}

fn not_built() -> Response {
    let body = format!(
        "<!doctype html>\n<meta charset=\"utf-8\">\n<title>kloub: web bundle not built</title>\n\
         <h1>web bundle not built: run <code>{RUN_COMMAND}</code></h1>\n\
         <p><code>kloub serve</code> found no <code>index.html</code> in its <code>--dist</code> folder.</p>\n"
    );
    let mut res = (StatusCode::INTERNAL_SERVER_ERROR, body).into_response();
    res.headers_mut().insert(
        CONTENT_TYPE,
        HeaderValue::from_static("text/html; charset=utf-8"),
    );
    res
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repo_dirs_resolve_from_any_current_dir() {
        let assets = repo_dir("web/assets");
        assert!(assets.ends_with("web/assets"));
        assert!(
            assets.join(DEFAULT_MODEL).is_file(),
            "{} has the default model",
            assets.display()
        );
        let config = ServeConfig::default();
        assert!(config.dist.ends_with("web/dist"));
    }
}
