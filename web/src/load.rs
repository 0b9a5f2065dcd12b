//! Getting model bytes into the app: fetching a URL, reading dropped files, and turning a
//! set of files into an imported [`Asset`].
//!
//! Reading is asynchronous in the browser, so every source delivers its files into an
//! [`Inbox`] that the app drains once per frame. Importing is platform independent and runs
//! on the frame that drains the delivery.

use std::cell::RefCell;
use std::rc::Rc;

use kloub_core::{Asset, ImportOptions, MapResolver, NoResolver, Resolver, Warning, import};

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
    /// The files, or the read error.
    pub files: Result<Vec<SourceFile>, String>,
}

/// A successfully imported model.
#[derive(Debug)]
pub struct LoadedModel {
    /// Display name: the model file's name.
    pub name: String,
    /// The imported asset.
    pub asset: Asset,
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
    let imported = import(&model.bytes, resolver.as_ref(), &ImportOptions::default()).map_err(|e| {
        if e.pointer.is_empty() {
            format!("{display}: {}", e.message)
        } else {
            format!("{display}: {}: {}", e.pointer, e.message)
        }
    })?;
    Ok(LoadedModel { name: display, asset: imported.asset, warnings: imported.warnings, sidecar })
}

/// Fetches `url` and delivers its bytes to `inbox`, then asks `ctx` for a repaint.
#[cfg(target_arch = "wasm32")]
pub fn fetch_into(url: String, inbox: Inbox, ctx: egui::Context) {
    wasm_bindgen_futures::spawn_local(async move {
        let name = file_name_of_url(&url).to_owned();
        let files = fetch_bytes(&url, &name, &inbox, &ctx).await.map(|bytes| vec![SourceFile { name, bytes }]);
        inbox.push(Delivery { url: Some(url.clone()), origin: url, files });
        ctx.request_repaint();
    });
}

/// Fetching needs a browser; natively the delivery is an error.
#[cfg(not(target_arch = "wasm32"))]
pub fn fetch_into(url: String, inbox: Inbox, ctx: egui::Context) {
    let files = Err(format!("{url}: fetching URLs is only available in the browser"));
    inbox.push(Delivery { url: Some(url.clone()), origin: url, files });
    ctx.request_repaint();
}

/// Fetches `url`, streaming the body so the app can show a progress bar.
#[cfg(target_arch = "wasm32")]
async fn fetch_bytes(url: &str, name: &str, inbox: &Inbox, ctx: &egui::Context) -> Result<Vec<u8>, String> {
    use wasm_bindgen::JsCast;
    use wasm_bindgen_futures::JsFuture;

    let window = web_sys::window().ok_or("no window")?;
    let response = JsFuture::from(window.fetch_with_str(url))
        .await
        .map_err(|e| format!("{url}: {}", crate::dom::js_error_text(&e)))?;
    let response: web_sys::Response =
        response.dyn_into().map_err(|_| format!("{url}: fetch did not return a Response"))?;
    if !response.ok() {
        return Err(format!("{url}: HTTP {} {}", response.status(), response.status_text()));
    }
    let fail = |e: wasm_bindgen::JsValue| format!("{url}: {}", crate::dom::js_error_text(&e));
    let total = response.headers().get("content-length").ok().flatten().and_then(|v| v.trim().parse::<u64>().ok());
    let Some(body) = response.body() else {
        let buffer = JsFuture::from(response.array_buffer().map_err(fail)?).await.map_err(fail)?;
        return Ok(js_sys::Uint8Array::new(&buffer).to_vec());
    };
    let reader: web_sys::ReadableStreamDefaultReader =
        body.get_reader().dyn_into().map_err(|_| format!("{url}: the body has no reader"))?;
    let mut bytes = Vec::with_capacity(total.map_or(0, |t| t.min(MAX_PREALLOCATE) as usize));
    loop {
        let chunk = JsFuture::from(reader.read()).await.map_err(fail)?;
        let done = js_sys::Reflect::get(&chunk, &"done".into()).map_err(fail)?.as_bool().unwrap_or(true);
        if done {
            break;
        }
        let value = js_sys::Reflect::get(&chunk, &"value".into()).map_err(fail)?;
        let array: js_sys::Uint8Array = value.dyn_into().map_err(|_| format!("{url}: a body chunk is not bytes"))?;
        let start = bytes.len();
        bytes.resize(start + array.length() as usize, 0);
        array.copy_to(&mut bytes[start..]);
        inbox.set_progress(Progress { name: name.to_owned(), received: bytes.len() as u64, total });
        ctx.request_repaint();
    }
    Ok(bytes)
}

/// Most bytes reserved up front from a `Content-Length` (a larger body grows as it arrives).
#[cfg(target_arch = "wasm32")]
const MAX_PREALLOCATE: u64 = 256 << 20;

/// Reads dropped files (asynchronously in the browser) and delivers them together.
pub fn read_dropped_into(dropped: Vec<egui::DroppedFileHandle>, inbox: Inbox, ctx: egui::Context) {
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
        inbox.push(Delivery { origin, url: None, files: error.map_or(Ok(files), Err) });
        ctx.request_repaint();
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
        inbox.push(Delivery { origin, url: None, files });
        ctx.request_repaint();
    }
}

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
    fn inbox_is_fifo() {
        let inbox = Inbox::default();
        inbox.push(Delivery { origin: "a".into(), url: None, files: Ok(Vec::new()) });
        inbox.push(Delivery { origin: "b".into(), url: None, files: Err("x".into()) });
        let got: Vec<String> = inbox.take().into_iter().map(|d| d.origin).collect();
        assert_eq!(got, ["a", "b"]);
        assert!(inbox.take().is_empty());
    }
}
