//! Getting model bytes into the app: fetching a URL, reading dropped files, and turning a
//! set of files into an imported [`Asset`].
//!
//! Reading is asynchronous in the browser, so every source delivers its files into an
//! [`Inbox`] that the app drains once per frame. Importing is platform independent and runs
//! on the frame that drains the delivery.

use std::cell::RefCell;
use std::rc::Rc;

use kloub_core::{Asset, ImportOptions, MapResolver, NoResolver, Resolver, Warning, import_with};

/// One file's name (no directories on the web) and contents.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceFile {
    /// File name, e.g. `Fox.glb`.
    pub name: String,
    /// Whole contents.
    pub bytes: Vec<u8>,
}

/// Files read from one source (a URL, or one drop), or why they could not be read.
#[derive(Debug)]
pub struct Delivery {
    /// Where the files came from, for messages (a URL or "dropped files").
    pub origin: String,
    /// The URL the files were fetched from (`None` for files from the user's disk).
    pub url: Option<String>,
    /// The files, or the read error (empty when they come as [`Delivery::shared`]).
    pub files: Result<Vec<SourceFile>, String>,
    /// The files of a download the page's viewers share ([`crate::shared`]); empty when the
    /// model was already shown by another viewer (take it from [`crate::shared::cached`]).
    pub shared: Option<crate::shared::SharedFiles>,
}

impl Delivery {
    /// The delivered files: the shared download's when there is one, else its own (empty on
    /// a read error).
    pub fn contents(&self) -> &[SourceFile] {
        match (&self.shared, &self.files) {
            (Some(shared), _) => shared,
            (None, Ok(files)) => files,
            (None, Err(_)) => &[],
        }
    }
}

/// A successfully imported model.
#[derive(Debug)]
pub struct LoadedModel {
    /// Display name: the model file's name.
    pub name: String,
    /// The imported asset (shared by every viewer of the page that shows the same URL).
    pub asset: std::sync::Arc<Asset>,
    /// Defects the importer repaired.
    pub warnings: Vec<Warning>,
    /// A `<model>.kloub.json` sidecar dropped with the model (joint limits, stiffness).
    pub sidecar: Option<String>,
}

/// How far a download has come: bytes received and, when the server said, the total.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Progress {
    /// What is being read (a file name).
    pub name: String,
    /// Bytes received so far.
    pub received: u64,
    /// `Content-Length`, when known.
    pub total: Option<u64>,
}

#[derive(Debug, Default)]
struct InboxState {
    deliveries: Vec<Delivery>,
    progress: Option<Progress>,
}

/// Deliveries waiting for the app, shared between the app and the async readers, and the
/// progress of the download under way.
#[derive(Clone, Debug, Default)]
pub struct Inbox(Rc<RefCell<InboxState>>);

impl Inbox {
    /// Queues a delivery (and ends the progress report).
    pub fn push(&self, delivery: Delivery) {
        let mut state = self.0.borrow_mut();
        state.deliveries.push(delivery);
        state.progress = None;
    }

    /// Takes every queued delivery, oldest first.
    pub fn take(&self) -> Vec<Delivery> {
        std::mem::take(&mut self.0.borrow_mut().deliveries)
    }

    /// Reports a download's progress.
    pub fn set_progress(&self, progress: Progress) {
        self.0.borrow_mut().progress = Some(progress);
    }

    /// The download under way, if any.
    pub fn progress(&self) -> Option<Progress> {
        self.0.borrow().progress.clone()
    }
}

/// Whether a file name looks like a glTF model (`.glb` or `.gltf`, any case).
pub fn is_model_name(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".glb") || lower.ends_with(".gltf")
}

/// Whether a file name is a Kloub sidecar (`<model>.kloub.json`, any case).
pub fn is_sidecar_name(name: &str) -> bool {
    name.to_ascii_lowercase().ends_with(".kloub.json")
}

/// The last path segment of a URL without query or fragment, e.g. `default.glb`.
pub fn file_name_of_url(url: &str) -> &str {
    let path = url.split(['?', '#']).next().unwrap_or(url);
    path.rsplit('/').find(|s| !s.is_empty()).unwrap_or(path)
}

/// Names of the models among `files` (`.glb`/`.gltf`), in the order given.
pub fn model_names(files: &[SourceFile]) -> Vec<String> {
    files.iter().filter(|f| is_model_name(&f.name)).map(|f| f.name.clone()).collect()
}

/// The folder part of a relative path (`"a/b/"` for `"a/b/c.gltf"`, `""` for `"c.gltf"`).
fn folder_of(name: &str) -> &str {
    name.rfind(['/', '\\']).map_or("", |i| &name[..=i])
}

/// The last segment of a relative path.
pub fn base_name(name: &str) -> &str {
    name.rsplit(['/', '\\']).next().unwrap_or(name)
}

/// Imports the model among `files`: the first `.glb`/`.gltf` (or the only file when none is
/// named so); the other files resolve its external URIs (`.bin`, textures).
///
/// # Errors
/// A message naming the file: nothing to import, or the importer's error with its JSON pointer.
pub fn import_files(files: Vec<SourceFile>) -> Result<LoadedModel, String> {
    import_model(&files, None)
}

/// Imports the model named `wanted` among `files` (default: the first model, or the only
/// file). Files may carry relative folders (a dropped folder): the model's URIs resolve
/// relative to its own folder, then by file name. A `<model>.kloub.json` among them is its
/// joint-settings sidecar.
///
/// # Errors
/// A message naming the file: nothing to import, or the importer's error with its JSON pointer.
pub fn import_model(files: &[SourceFile], wanted: Option<&str>) -> Result<LoadedModel, String> {
    let sidecar = match files.iter().find(|f| is_sidecar_name(&f.name)) {
        Some(f) => Some(String::from_utf8(f.bytes.clone()).map_err(|_| format!("{}: not UTF-8 text", f.name))?),
        None => None,
    };
    let candidates: Vec<&SourceFile> = files.iter().filter(|f| !is_sidecar_name(&f.name)).collect();
    let main = match wanted {
        Some(name) => {
            candidates.iter().position(|f| f.name == name).ok_or_else(|| format!("{name}: not among the files"))?
        }
        None => match candidates.iter().position(|f| is_model_name(&f.name)) {
            Some(i) => i,
            None if candidates.len() == 1 => 0,
            None if candidates.is_empty() => return Err("no files to open".to_owned()),
            None => return Err("none of the dropped files is a .glb or .gltf model".to_owned()),
        },
    };
    let model = candidates[main];
    let folder = folder_of(&model.name);
    let others: Vec<&SourceFile> =
        candidates.iter().enumerate().filter(|&(i, f)| i != main && !is_model_name(&f.name)).map(|(_, f)| *f).collect();
    let resolver: Box<dyn Resolver> = if others.is_empty() {
        Box::new(NoResolver)
    } else {
        let mut map = MapResolver::new();
        for file in others {
            let key = file.name.strip_prefix(folder).unwrap_or(&file.name);
            map.insert(key.to_owned(), file.bytes.clone());
        }
        Box::new(map)
    };
    let display = base_name(&model.name).to_owned();
    let imported =
        crate::codecs::with(|codecs| import_with(&model.bytes, resolver.as_ref(), codecs, &ImportOptions::default()))
            .map_err(|e| {
            if e.pointer.is_empty() {
                format!("{display}: {}", e.message)
            } else {
                format!("{display}: {}: {}", e.pointer, e.message)
            }
        })?;
    Ok(LoadedModel { name: display, asset: std::sync::Arc::new(imported.asset), warnings: imported.warnings, sidecar })
}

/// Most external files a `.gltf` fetched from a URL may name.
const MAX_SIBLINGS: usize = 1024;

/// Fetches `url` and delivers its bytes to `inbox`, then wakes the viewer. A `.gltf`
/// brings its relative buffers and images along, fetched relative to its URL (the total within
/// the import budget); a `.zip` is expanded when the delivery is imported.
#[cfg(target_arch = "wasm32")]
pub fn fetch_into(url: String, inbox: Inbox, wake: crate::control::Wake) {
    // Another viewer of the page shows it: no download, no import.
    if crate::shared::cached(&url).is_some() {
        inbox.push(Delivery {
            url: Some(url.clone()),
            origin: url,
            files: Ok(Vec::new()),
            shared: Some(std::rc::Rc::new(Vec::new())),
        });
        wake.wake();
        return;
    }
    // Another viewer is downloading it: its delivery comes with that one.
    if !crate::shared::join_fetch(&url, &inbox, &wake) {
        return;
    }
    wasm_bindgen_futures::spawn_local(async move {
        // `model.glb#sidecar=model.kloub.json`: the model with its sidecar (a sample's example poses).
        let (model, sidecar) = split_sidecar(&url);
        let fetched = fetch_model(model, &inbox, &wake).await;
        let fetched = match (fetched, sidecar) {
            (Ok(mut files), Some(sidecar)) => match fetch_sidecar(model, sidecar, &inbox, &wake).await {
                Ok(file) => {
                    files.push(file);
                    Ok(files)
                }
                Err(e) => Err(e),
            },
            (fetched, _) => fetched,
        };
        let (files, shared) = match fetched {
            Ok(files) => (Ok(Vec::new()), Some(std::rc::Rc::new(files))),
            Err(e) => (Err(e), None),
        };
        for (inbox, wake) in crate::shared::finish_fetch(&url) {
            inbox.push(Delivery {
                url: Some(url.clone()),
                origin: url.clone(),
                files: files.clone(),
                shared: shared.clone(),
            });
            wake.wake();
        }
    });
}

/// The model at `url`, with the files a `.gltf` names beside it.
#[cfg(target_arch = "wasm32")]
async fn fetch_model(url: &str, inbox: &Inbox, wake: &crate::control::Wake) -> Result<Vec<SourceFile>, String> {
    let mut name = file_name_of_url(url).to_owned();
    let budget = kloub_core::ImportOptions::default().budget_bytes;
    let bytes = fetch_bytes(url, &name, budget, inbox, wake).await?;
    let gltf = is_gltf_json(&name, &bytes);
    // A glTF behind an address that hides its name (`/api/model?id=3`) is named as one.
    if gltf && !name.to_ascii_lowercase().ends_with(".gltf") {
        name.push_str(".gltf");
    }
    let siblings = if gltf { external_uris(&bytes) } else { Vec::new() };
    let mut total = bytes.len() as u64;
    let mut files = vec![SourceFile { name, bytes }];
    if siblings.is_empty() {
        return Ok(files);
    }
    let base = absolute_url(url)?;
    for uri in siblings {
        let address = web_sys::Url::new_with_base(&uri, &base)
            .map_err(|_| format!("{url}: the URI {uri:?} it names is not a valid URL"))?
            .href();
        // An absolute address is kept under its URI, as the importer asks for it.
        let name =
            if kloub_core::import::is_web_uri(&uri) { uri.clone() } else { kloub_core::import::percent_decode(&uri) };
        let left = budget.saturating_sub(total);
        let bytes = fetch_bytes(&address, base_name(&name), left, inbox, wake).await?;
        total += bytes.len() as u64;
        files.push(SourceFile { name, bytes });
    }
    Ok(files)
}

/// `model.glb#sidecar=model.kloub.json` split into the model's URL and its sidecar's (relative
/// to the model's); a URL without that fragment has no sidecar.
pub fn split_sidecar(url: &str) -> (&str, Option<&str>) {
    match url.split_once("#sidecar=") {
        Some((model, sidecar)) if !sidecar.is_empty() => (model, Some(sidecar)),
        _ => (url, None),
    }
}

/// The sidecar at `sidecar` (relative to `model`'s URL), named `<model>.kloub.json` so that it
/// is imported with the model.
#[cfg(target_arch = "wasm32")]
async fn fetch_sidecar(
    model: &str,
    sidecar: &str,
    inbox: &Inbox,
    wake: &crate::control::Wake,
) -> Result<SourceFile, String> {
    let base = absolute_url(model)?;
    let address = web_sys::Url::new_with_base(sidecar, &base)
        .map_err(|_| format!("{model}: the sidecar {sidecar:?} is not a valid URL"))?
        .href();
    let stem = file_name_of_url(model).rsplit_once('.').map_or(file_name_of_url(model), |(stem, _)| stem);
    let name = format!("{stem}.kloub.json");
    let bytes = fetch_bytes(&address, &name, MAX_SIDECAR_BYTES, inbox, wake).await?;
    Ok(SourceFile { name, bytes })
}

/// Largest sidecar fetched with a model (example poses hold offsets per vertex).
#[cfg(target_arch = "wasm32")]
const MAX_SIDECAR_BYTES: u64 = 64 << 20;

/// `url` made absolute against the document's base URL (its `<base href>`, else the page's
/// address), as `fetch` and the element resolve it.
#[cfg(target_arch = "wasm32")]
fn absolute_url(url: &str) -> Result<String, String> {
    let window = web_sys::window();
    let base = window.as_ref().and_then(web_sys::Window::document).and_then(|d| d.base_uri().ok().flatten());
    let page = base.or_else(|| window.and_then(|w| w.location().href().ok())).unwrap_or_default();
    web_sys::Url::new_with_base(url, &page).map(|u| u.href()).map_err(|_| format!("{url}: not a valid URL"))
}

/// Whether a fetched file is a JSON glTF (by name, or by a leading `{` when the URL hides it).
pub fn is_gltf_json(name: &str, bytes: &[u8]) -> bool {
    name.to_ascii_lowercase().ends_with(".gltf")
        || (!name.to_ascii_lowercase().ends_with(".glb")
            && bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{'))
}

/// The relative URIs a JSON glTF's buffers and images name (not `data:` URIs, not absolute
/// URLs), in order, each once; at most [`MAX_SIBLINGS`]. Nothing when it is not JSON.
pub fn external_uris(gltf: &[u8]) -> Vec<String> {
    let Ok(doc) = serde_json::from_slice::<serde_json::Value>(gltf) else { return Vec::new() };
    let mut uris: Vec<String> = Vec::new();
    for list in ["buffers", "images"] {
        let items = doc.get(list).and_then(serde_json::Value::as_array).map_or(&[][..], Vec::as_slice);
        for item in items {
            let Some(uri) = item.get("uri").and_then(serde_json::Value::as_str) else { continue };
            // Anything with a scheme (`data:`, `https:host/x`), or rooted (`/x`, `\\host\x`), is not beside the file.
            let scheme = uri.split_once(':').is_some_and(|(head, _)| {
                !head.is_empty() && head.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
            });
            // Except absolute web addresses: fetched as they are (their server must allow CORS).
            let absolute = (scheme && !kloub_core::import::is_web_uri(uri)) || uri.starts_with(['/', '\\']);
            if !absolute && !uri.is_empty() && !uris.iter().any(|u| u == uri) && uris.len() < MAX_SIBLINGS {
                uris.push(uri.to_owned());
            }
        }
    }
    uris
}

/// Replaces each zip archive among `files` by the files inside it (paths kept, under a folder
/// named after the archive); returns them with a warning per entry the archive left out.
///
/// # Errors
/// An archive that cannot be read, is over the import budget (a zip bomb: refused before it
/// is inflated), or holds no model; the message names the archive.
pub fn expand_archives(files: Vec<SourceFile>) -> Result<(Vec<SourceFile>, Vec<Warning>), String> {
    use kloub_core::archive::{ArchiveLimits, is_zip};
    let mut out = Vec::with_capacity(files.len());
    let mut notes = Vec::new();
    for file in files {
        // By extension, or by content for a name without one (a URL that hides it): a `.bin`
        // that happens to start with `PK` stays a `.bin`.
        let base = base_name(&file.name);
        let by_name = base.to_ascii_lowercase().ends_with(".zip");
        if !(by_name || (!base.contains('.') && is_zip(&file.bytes))) {
            out.push(file);
            continue;
        }
        let archive = crate::codecs::with(|codecs| codecs.unzip(&file.bytes, &ArchiveLimits::default()))
            .map_err(|e| format!("{}: {e}", file.name))?;
        if archive.models().is_empty() {
            return Err(format!("{}: the archive holds no .glb or .gltf model", file.name));
        }
        // Under the archive's own name: two archives each holding `scene.gltf` + `scene.bin` stay apart.
        let zip_name = base_name(&file.name).to_owned();
        let stem = zip_name.rsplit_once('.').map_or(zip_name.as_str(), |(stem, _)| stem);
        let folder = format!("{}{stem}/", folder_of(&file.name));
        notes.extend(archive.skipped.iter().map(|m| Warning::new("", format!("{zip_name}: {m}"))));
        out.extend(
            archive.entries.into_iter().map(|e| SourceFile { name: format!("{folder}{}", e.path), bytes: e.bytes }),
        );
    }
    Ok((out, notes))
}

/// Fetching needs a browser; natively the delivery is an error.
#[cfg(not(target_arch = "wasm32"))]
pub fn fetch_into(url: String, inbox: Inbox, wake: crate::control::Wake) {
    let files = Err(format!("{url}: fetching URLs is only available in the browser"));
    inbox.push(Delivery { url: Some(url.clone()), origin: url, files, shared: None });
    wake.wake();
}

/// Milliseconds without progress (no answer, then no chunk of the body) before a fetch gives up.
#[cfg(target_arch = "wasm32")]
const ANSWER_TIMEOUT_MS: i32 = 30_000;

/// Milliseconds the CORS probe of a failed fetch may take.
#[cfg(target_arch = "wasm32")]
const PROBE_TIMEOUT_MS: i32 = 10_000;

/// An HTTP error status as a user can act on it: `"URL: HTTP 404 Not Found: the server has no
/// file at this address"`.
pub fn http_error(url: &str, status: u16, text: &str) -> String {
    let hint = match status {
        404 => "the server has no file at this address",
        410 => "the file was removed from this address",
        401 | 403 => "the server refuses to give it (it needs permission)",
        429 => "the server is asked too often: try again later",
        500..=599 => "the server failed to answer",
        _ => "",
    };
    let text = if text.is_empty() { String::new() } else { format!(" {text}") };
    if hint.is_empty() { format!("{url}: HTTP {status}{text}") } else { format!("{url}: HTTP {status}{text}: {hint}") }
}

/// Why a fetch of `url` failed, for a user who can act on it (the browser only says "Failed to
/// fetch"): its CSP, the other server's CORS headers, the network, or the time limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FetchFailure {
    /// No answer within the time limit.
    Timeout,
    /// The page's Content-Security-Policy does not allow the origin.
    Csp,
    /// The other origin answered, but without `Access-Control-Allow-Origin`.
    Cors,
    /// Nothing answered (down, wrong address, refused, offline).
    Network,
}

impl FetchFailure {
    /// The message for a failed fetch of `url` (on `origin`, from a page on `page_origin`).
    pub fn message(self, url: &str, origin: &str, page_origin: &str) -> String {
        match self {
            FetchFailure::Timeout => format!("{url}: timed out: {origin} did not answer within 30 s"),
            FetchFailure::Csp => format!(
                "{url}: this page's Content-Security-Policy does not allow fetching from {origin} (its connect-src); \
                 `kloub serve --connect-src` lists the origins a deployment allows"
            ),
            FetchFailure::Cors => format!(
                "{url}: the server at {origin} does not allow cross-origin requests (CORS): its answer has no \
                 Access-Control-Allow-Origin header. Add `Access-Control-Allow-Origin: *` (or {page_origin}) to its \
                 responses, or serve the model from this page's server"
            ),
            FetchFailure::Network => format!(
                "{url}: network error: {origin} could not be reached (the server is down, the address is wrong, \
                 or the connection was refused)"
            ),
        }
    }
}

/// Origins blocked by the page's CSP while it is alive (`securitypolicyviolation` events).
#[cfg(target_arch = "wasm32")]
struct CspWatch {
    document: Option<web_sys::Document>,
    blocked: Rc<RefCell<Vec<String>>>,
    listener: wasm_bindgen::closure::Closure<dyn FnMut(web_sys::SecurityPolicyViolationEvent)>,
}

#[cfg(target_arch = "wasm32")]
impl CspWatch {
    fn start(window: &web_sys::Window) -> Self {
        use wasm_bindgen::JsCast;
        let blocked: Rc<RefCell<Vec<String>>> = Rc::default();
        let seen = blocked.clone();
        let listener = wasm_bindgen::closure::Closure::<dyn FnMut(web_sys::SecurityPolicyViolationEvent)>::new(
            move |event: web_sys::SecurityPolicyViolationEvent| seen.borrow_mut().push(event.blocked_uri()),
        );
        let document = window.document();
        if let Some(d) = &document {
            let _ = d.add_event_listener_with_callback("securitypolicyviolation", listener.as_ref().unchecked_ref());
        }
        Self { document, blocked, listener }
    }

    /// Whether a fetch to `origin` was blocked (reports name the origin or the whole URL).
    fn blocked(&self, origin: &str) -> bool {
        self.blocked.borrow().iter().any(|uri| uri.starts_with(origin))
    }
}

#[cfg(target_arch = "wasm32")]
impl Drop for CspWatch {
    fn drop(&mut self) {
        use wasm_bindgen::JsCast;
        if let Some(d) = &self.document {
            let _ = d
                .remove_event_listener_with_callback("securitypolicyviolation", self.listener.as_ref().unchecked_ref());
        }
    }
}

/// Resolves after `ms` milliseconds (lets queued events, such as CSP reports, arrive).
#[cfg(target_arch = "wasm32")]
async fn sleep(window: &web_sys::Window, ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        let _ = window.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, ms);
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}

/// Finds out why the fetch of `url` failed: a CSP report for its origin, else (for another
/// origin) a `no-cors` probe: an answer means the server is there but sends no CORS headers,
/// none means the network (or the CSP, reported now).
#[cfg(target_arch = "wasm32")]
async fn explain_failure(window: &web_sys::Window, url: &str, timed_out: bool, watch: &CspWatch) -> String {
    use wasm_bindgen_futures::JsFuture;
    let absolute = absolute_url(url).unwrap_or_else(|_| url.to_owned());
    let origin = web_sys::Url::new(&absolute).map(|u| u.origin()).unwrap_or_else(|_| absolute.clone());
    let page_origin = window.location().origin().unwrap_or_default();
    if timed_out {
        return FetchFailure::Timeout.message(url, &origin, &page_origin);
    }
    sleep(window, 0).await;
    if watch.blocked(&origin) {
        return FetchFailure::Csp.message(url, &origin, &page_origin);
    }
    if origin == page_origin {
        return FetchFailure::Network.message(url, &origin, &page_origin);
    }
    let init = web_sys::RequestInit::new();
    init.set_mode(web_sys::RequestMode::NoCors);
    // The probe gets its own short limit; its (opaque) body is never read.
    let controller = web_sys::AbortController::new().ok();
    if let Some(c) = &controller {
        init.set_signal(Some(&c.signal()));
    }
    let stop = controller.clone();
    let abort = wasm_bindgen::closure::Closure::<dyn FnMut()>::new(move || {
        if let Some(c) = &stop {
            c.abort();
        }
    });
    let timer = {
        use wasm_bindgen::JsCast;
        window.set_timeout_with_callback_and_timeout_and_arguments_0(abort.as_ref().unchecked_ref(), PROBE_TIMEOUT_MS)
    }
    .unwrap_or(0);
    let probe = JsFuture::from(window.fetch_with_str_and_init(&absolute, &init)).await;
    window.clear_timeout_with_handle(timer);
    drop(abort);
    if let (Ok(answer), Some(c)) = (&probe, &controller) {
        use wasm_bindgen::JsCast;
        if let Some(body) = answer.dyn_ref::<web_sys::Response>().and_then(web_sys::Response::body) {
            let _ = body.cancel();
        }
        c.abort();
    }
    sleep(window, 0).await;
    let failure = match probe {
        Ok(_) => FetchFailure::Cors,
        Err(_) if watch.blocked(&origin) => FetchFailure::Csp,
        Err(_) => FetchFailure::Network,
    };
    failure.message(url, &origin, &page_origin)
}

/// Fetches `url`, streaming the body so the app can show a progress bar. A failure says why
/// ([`http_error`], [`FetchFailure`]).
#[cfg(target_arch = "wasm32")]
async fn fetch_bytes(
    url: &str,
    name: &str,
    limit: u64,
    inbox: &Inbox,
    wake: &crate::control::Wake,
) -> Result<Vec<u8>, String> {
    use wasm_bindgen::JsCast;
    use wasm_bindgen_futures::JsFuture;

    let window = web_sys::window().ok_or("no window")?;
    let controller = web_sys::AbortController::new().map_err(|_| format!("{url}: AbortController is unavailable"))?;
    let signal = controller.signal();
    let init = web_sys::RequestInit::new();
    init.set_signal(Some(&signal));
    // The element's download of this URL, started while the module loaded.
    let prefetch = crate::prefetch::take_download(url);
    let prefetch_abort = prefetch.as_ref().map(|(_, abort)| abort.clone());
    // One watchdog for the answer and then for every chunk of the body: no progress for
    // ANSWER_TIMEOUT_MS aborts the fetch (and its stream). Kept alive until its timer is cleared.
    let abort = wasm_bindgen::closure::Closure::<dyn FnMut()>::new(move || {
        controller.abort();
        if let Some(abort) = &prefetch_abort {
            let _ = abort.call0(&wasm_bindgen::JsValue::NULL);
        }
    });
    let arm = || {
        window
            .set_timeout_with_callback_and_timeout_and_arguments_0(abort.as_ref().unchecked_ref(), ANSWER_TIMEOUT_MS)
            .unwrap_or(0)
    };
    let mut timer = arm();
    let watch = CspWatch::start(&window);
    let answer = match prefetch {
        // A failed prefetch is fetched again, so that the failure is explained as for any fetch.
        Some((response, _)) => match JsFuture::from(response).await {
            Ok(response) => Ok(response),
            Err(_) => JsFuture::from(window.fetch_with_str_and_init(url, &init)).await,
        },
        None => JsFuture::from(window.fetch_with_str_and_init(url, &init)).await,
    };
    let response = match answer {
        Ok(response) => response,
        Err(_) => {
            window.clear_timeout_with_handle(timer);
            return Err(explain_failure(&window, url, signal.aborted(), &watch).await);
        }
    };
    drop(watch);
    let result = async {
        let response: web_sys::Response =
            response.dyn_into().map_err(|_| format!("{url}: fetch did not return a Response"))?;
        if !response.ok() {
            return Err(http_error(url, response.status(), &response.status_text()));
        }
        let fail = |e: wasm_bindgen::JsValue| {
            if signal.aborted() {
                format!("{url}: stalled: no data for {} s", ANSWER_TIMEOUT_MS / 1000)
            } else {
                format!("{url}: {}", crate::dom::js_error_text(&e))
            }
        };
        let over = || format!("{url}: larger than the {limit} bytes left of the import budget");
        let total = response.headers().get("content-length").ok().flatten().and_then(|v| v.trim().parse::<u64>().ok());
        if total.is_some_and(|t| t > limit) {
            return Err(over());
        }
        let Some(body) = response.body() else {
            let buffer = JsFuture::from(response.array_buffer().map_err(fail)?).await.map_err(fail)?;
            let bytes = js_sys::Uint8Array::new(&buffer).to_vec();
            return if bytes.len() as u64 > limit { Err(over()) } else { Ok(bytes) };
        };
        let reader: web_sys::ReadableStreamDefaultReader =
            body.get_reader().dyn_into().map_err(|_| format!("{url}: the body has no reader"))?;
        let mut bytes = Vec::with_capacity(total.map_or(0, |t| t.min(MAX_PREALLOCATE) as usize));
        loop {
            let chunk = JsFuture::from(reader.read()).await.map_err(fail)?;
            window.clear_timeout_with_handle(timer);
            timer = arm();
            let done = js_sys::Reflect::get(&chunk, &"done".into()).map_err(fail)?.as_bool().unwrap_or(true);
            if done {
                break;
            }
            let value = js_sys::Reflect::get(&chunk, &"value".into()).map_err(fail)?;
            let array: js_sys::Uint8Array =
                value.dyn_into().map_err(|_| format!("{url}: a body chunk is not bytes"))?;
            if bytes.len() as u64 + u64::from(array.length()) > limit {
                let _ = reader.cancel();
                return Err(over());
            }
            let start = bytes.len();
            bytes.resize(start + array.length() as usize, 0);
            array.copy_to(&mut bytes[start..]);
            inbox.set_progress(Progress { name: name.to_owned(), received: bytes.len() as u64, total });
            wake.wake();
        }
        Ok(bytes)
    }
    .await;
    window.clear_timeout_with_handle(timer);
    drop(abort);
    result
}

/// Most bytes reserved up front from a `Content-Length` (a larger body grows as it arrives).
#[cfg(target_arch = "wasm32")]
const MAX_PREALLOCATE: u64 = 256 << 20;

/// Reads dropped files (asynchronously in the browser) and delivers them together.
#[cfg(feature = "full")]
pub fn read_dropped_into(dropped: Vec<egui::DroppedFileHandle>, inbox: Inbox, wake: crate::control::Wake) {
    let origin = "dropped files".to_owned();
    #[cfg(target_arch = "wasm32")]
    wasm_bindgen_futures::spawn_local(async move {
        let mut files = Vec::with_capacity(dropped.len());
        let mut error = None;
        for file in &dropped {
            let name = file_name_of_path(file.path());
            match file.bytes_async().await {
                Ok(bytes) => files.push(SourceFile { name, bytes }),
                Err(e) => {
                    error = Some(format!("{name}: {e}"));
                    break;
                }
            }
        }
        inbox.push(Delivery { origin, url: None, files: error.map_or(Ok(files), Err), shared: None });
        wake.wake();
    });
    #[cfg(not(target_arch = "wasm32"))]
    {
        let files = dropped
            .iter()
            .map(|file| {
                let name = file_name_of_path(file.path());
                file.bytes().map(|bytes| SourceFile { name: name.clone(), bytes }).map_err(|e| format!("{name}: {e}"))
            })
            .collect();
        inbox.push(Delivery { origin, url: None, files, shared: None });
        wake.wake();
    }
}

#[cfg(feature = "full")]
fn file_name_of_path(path: &std::path::Path) -> String {
    path.file_name().map_or_else(|| path.to_string_lossy(), |n| n.to_string_lossy()).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn url_file_names() {
        assert_eq!(file_name_of_url("/models/default.glb"), "default.glb");
        assert_eq!(file_name_of_url("http://h/a/Fox.glb?x=1#y"), "Fox.glb");
        assert_eq!(file_name_of_url("dir/"), "dir");
        assert_eq!(file_name_of_url("plain"), "plain");
    }

    #[test]
    fn model_names() {
        assert!(is_model_name("Fox.GLB"));
        assert!(is_model_name("a.gltf"));
        assert!(!is_model_name("a.bin"));
        assert!(!is_model_name("glb"));
    }

    #[test]
    fn nothing_to_import() {
        let err = import_files(Vec::new()).err();
        assert_eq!(err.as_deref(), Some("no files to open"));
        let two = vec![
            SourceFile { name: "a.bin".into(), bytes: vec![1] },
            SourceFile { name: "b.png".into(), bytes: vec![2] },
        ];
        assert!(import_files(two).err().is_some_and(|e| e.contains(".glb or .gltf")));
    }

    #[test]
    fn bad_file_is_an_error_naming_the_file() {
        let bad = vec![SourceFile { name: "broken.glb".into(), bytes: b"glTF\x02\0\0\0garbage".to_vec() }];
        let err = import_files(bad).err();
        assert!(err.as_deref().is_some_and(|e| e.starts_with("broken.glb: ")), "{err:?}");
    }

    fn shared(path: &str) -> SourceFile {
        let full = format!("{}/../tests/assets/khronos/{path}", env!("CARGO_MANIFEST_DIR"));
        let bytes = std::fs::read(&full).unwrap_or_else(|e| panic!("{full}: {e}"));
        let name = path.rsplit('/').next().unwrap_or(path).to_owned();
        SourceFile { name, bytes }
    }

    #[test]
    fn gltf_with_its_bin_in_any_order() {
        let files = vec![shared("RiggedSimple/glTF/RiggedSimple0.bin"), shared("RiggedSimple/glTF/RiggedSimple.gltf")];
        let model = import_files(files).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(model.name, "RiggedSimple.gltf");
        assert_eq!(model.asset.clips.len(), 1);
        assert_eq!(model.asset.skins.len(), 1);
    }

    #[test]
    fn gltf_without_its_bin_names_the_buffer() {
        let err = import_files(vec![shared("RiggedSimple/glTF/RiggedSimple.gltf")]).err();
        assert!(err.as_deref().is_some_and(|e| e.starts_with("RiggedSimple.gltf: /buffers/0")), "{err:?}");
    }

    #[test]
    fn folder_paths_resolve_relative_to_the_model() {
        let mut files =
            vec![shared("RiggedSimple/glTF/RiggedSimple.gltf"), shared("RiggedSimple/glTF/RiggedSimple0.bin")];
        files[0].name = "drop/glTF/RiggedSimple.gltf".into();
        files[1].name = "drop/glTF/RiggedSimple0.bin".into();
        // A same-named decoy elsewhere in the folder must not be picked.
        files.push(SourceFile { name: "drop/other/RiggedSimple0.bin".into(), bytes: vec![0; 4] });
        let model = import_model(&files, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(model.name, "RiggedSimple.gltf");
        assert_eq!(model.asset.skins.len(), 1);
    }

    #[test]
    fn several_models_are_listed_and_picked_by_name() {
        let files = vec![
            shared("RiggedSimple/glTF-Binary/RiggedSimple.glb"),
            shared("Fox/glTF-Binary/Fox.glb"),
            SourceFile { name: "notes.txt".into(), bytes: b"hi".to_vec() },
        ];
        assert_eq!(super::model_names(&files), ["RiggedSimple.glb", "Fox.glb"]);
        assert_eq!(import_model(&files, None).map(|m| m.name), Ok("RiggedSimple.glb".to_owned()));
        let fox = import_model(&files, Some("Fox.glb")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(fox.asset.clips.len(), 3);
        assert!(import_model(&files, Some("Cat.glb")).is_err());
    }

    #[test]
    fn a_gltf_names_its_relative_and_web_files_once_and_data_or_rooted_uris_not_at_all() {
        let gltf = br#"{"buffers": [{"uri": "data%20file.bin"}, {"uri": "data:application/octet-stream;base64,AAAA"},
                        {"uri": "https://cdn.example/x.bin"}, {"uri": "data%20file.bin"}, {}, {"uri": "https:host/y.bin"},
                        {"uri": "\\\\host\\z.bin"}],
                        "images": [{"uri": "tex/skin.png"}, {"bufferView": 0}, {"uri": "/abs.png"}]}"#;
        assert_eq!(external_uris(gltf), ["data%20file.bin", "https://cdn.example/x.bin", "tex/skin.png"]);
        assert!(external_uris(b"not json").is_empty());
        assert!(is_gltf_json("Man.gltf", b""));
        assert!(is_gltf_json("model", b"  {\"asset\": {}}"));
        assert!(!is_gltf_json("Man.glb", b"{"));
        let decode = kloub_core::import::percent_decode;
        assert_eq!(decode("data%20file.bin"), "data file.bin");
        assert_eq!(decode("a%2"), "a%2");
        assert_eq!(decode("%C3%A9t%C3%A9.png"), "été.png");
    }

    #[test]
    fn load_errors_say_what_a_user_can_do() {
        let e = http_error("http://h/x.glb", 404, "Not Found");
        assert_eq!(e, "http://h/x.glb: HTTP 404 Not Found: the server has no file at this address");
        assert!(http_error("u", 403, "Forbidden").contains("permission"));
        assert_eq!(http_error("u", 418, ""), "u: HTTP 418");
        let cors = FetchFailure::Cors.message("http://b/x.glb", "http://b", "http://a");
        assert!(
            cors.contains("CORS") && cors.contains("Access-Control-Allow-Origin") && cors.contains("http://b/x.glb")
        );
        assert!(FetchFailure::Csp.message("u", "http://b", "http://a").contains("Content-Security-Policy"));
        assert!(FetchFailure::Network.message("u", "http://b", "http://a").contains("network error"));
        assert!(FetchFailure::Timeout.message("u", "http://b", "http://a").contains("timed out"));
    }

    fn zipped(files: &[(&str, &[u8])]) -> Vec<u8> {
        use std::io::Write;
        let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        for (name, bytes) in files {
            out.start_file(*name, options).expect("start");
            out.write_all(bytes).expect("write");
        }
        out.finish().expect("finish").into_inner()
    }

    #[test]
    fn a_zipped_gltf_folder_opens_like_the_folder() {
        let gltf = shared("RiggedSimple/glTF/RiggedSimple.gltf");
        let bin = shared("RiggedSimple/glTF/RiggedSimple0.bin");
        let archive = zipped(&[
            ("Simple/glTF/RiggedSimple.gltf", &gltf.bytes),
            ("Simple/glTF/RiggedSimple0.bin", &bin.bytes),
            ("../../etc/passwd", b"x"),
        ]);
        let (files, notes) = expand_archives(vec![SourceFile { name: "drop/Simple.zip".into(), bytes: archive }])
            .unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = files.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["drop/Simple/Simple/glTF/RiggedSimple.gltf", "drop/Simple/Simple/glTF/RiggedSimple0.bin"]);
        assert_eq!(notes.len(), 1);
        assert!(notes[0].message.starts_with("Simple.zip: ") && notes[0].message.contains("../../etc/passwd"));
        let model = import_model(&files, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((model.name.as_str(), model.asset.skins.len()), ("RiggedSimple.gltf", 1));

        let nothing = zipped(&[("readme.txt", b"hi")]);
        let err = expand_archives(vec![SourceFile { name: "x.zip".into(), bytes: nothing }]).err();
        assert!(err.is_some_and(|e| e.contains("x.zip") && e.contains("no .glb or .gltf")));
        let broken =
            expand_archives(vec![SourceFile { name: "y.zip".into(), bytes: b"PK\x03\x04junk".to_vec() }]).err();
        assert!(broken.is_some_and(|e| e.starts_with("y.zip: ")));
        let plain = vec![
            SourceFile { name: "Fox.glb".into(), bytes: b"glTF".to_vec() },
            SourceFile { name: "indices.bin".into(), bytes: b"PK\x03\x04 by chance".to_vec() },
        ];
        assert_eq!(
            expand_archives(plain.clone()).map(|(f, _)| f),
            Ok(plain),
            "only .zip names, or names without an extension, are sniffed"
        );
        // Two archives with the same inner names stay apart.
        let a = zipped(&[("scene.gltf", &gltf.bytes), ("RiggedSimple0.bin", &bin.bytes)]);
        let (two, _) = expand_archives(vec![
            SourceFile { name: "a.zip".into(), bytes: a.clone() },
            SourceFile { name: "b.zip".into(), bytes: a },
        ])
        .unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = two.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["a/scene.gltf", "a/RiggedSimple0.bin", "b/scene.gltf", "b/RiggedSimple0.bin"]);
        // A zip behind a URL without a name is found by its content.
        let sniffed =
            expand_archives(vec![SourceFile { name: "download".into(), bytes: zipped(&[("m.glb", b"glTF")]) }]);
        assert_eq!(
            sniffed.map(|(f, _)| f.into_iter().map(|f| f.name).collect::<Vec<_>>()),
            Ok(vec!["download/m.glb".to_owned()])
        );
    }

    #[test]
    fn inbox_is_fifo() {
        let inbox = Inbox::default();
        inbox.push(Delivery { origin: "a".into(), url: None, files: Ok(Vec::new()), shared: None });
        inbox.push(Delivery { origin: "b".into(), url: None, files: Err("x".into()), shared: None });
        let got: Vec<String> = inbox.take().into_iter().map(|d| d.origin).collect();
        assert_eq!(got, ["a", "b"]);
        assert!(inbox.take().is_empty());
    }

    #[test]
    fn a_shared_download_s_files_are_its_contents() {
        let file = SourceFile { name: "Knight.glb".into(), bytes: vec![7; 10] };
        let shared = Delivery {
            origin: "u".into(),
            url: Some("u".into()),
            files: Ok(Vec::new()),
            shared: Some(std::rc::Rc::new(vec![file.clone()])),
        };
        assert_eq!(shared.contents(), std::slice::from_ref(&file), "sized for the parsing notice like any other");
        let own = Delivery { origin: "d".into(), url: None, files: Ok(vec![file.clone()]), shared: None };
        assert_eq!(own.contents().len(), 1);
        let failed = Delivery { origin: "e".into(), url: None, files: Err("x".into()), shared: None };
        assert!(failed.contents().is_empty());
    }
}
