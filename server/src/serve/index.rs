//! The `/api/assets` index: every `.glb`/`.gltf` of the sample library, imported once at
//! start-up with `kloub_core::import`, so the index lists what the viewer will actually find.
//!
//! Per model: its files (the model, then the external buffers and images it loads), their total
//! size, its licence text, its clip names and joint count. A model that does not import is still
//! listed, with an `error` and what was learned before the failure.

use super::files::Root;
use crate::paths::{self, percent_encode_segment};
use kloub_core::{ImportOptions, Resolver};
use serde::Serialize;
use std::cell::RefCell;

/// Licence texts longer than this are cut (at a character boundary).
const MAX_LICENCE_BYTES: usize = 8 * 1024;

/// One model in the asset library.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct AssetEntry {
    /// File name without extension.
    pub name: String,
    /// URL path of the model file (`/assets/...`, percent-encoded).
    pub url: String,
    /// URL paths of every file the model needs: the model first, then external buffers and
    /// images in the order the importer loaded them.
    pub files: Vec<String>,
    /// Total size of `files` in bytes.
    pub size: u64,
    /// Licence text: the nearest `<stem>.LICENSE.md`, `LICENSE.md`, `LICENSE` or `LICENSE.txt`
    /// in the model's folder or a folder above it (within the library), else the first line of
    /// a `README.md` there that mentions a licence or copyright; `null` when none.
    pub licence: Option<String>,
    /// One line to credit the model with, shown next to it in the app: the first paragraph of
    /// `licence` that is not a Markdown heading, its lines joined; `null` without a licence.
    pub attribution: Option<String>,
    /// Whether this is the model the page opens with (`/models/default.glb`).
    pub default: bool,
    /// Clip names (`clip N` for unnamed clips), in file order.
    pub clips: Vec<String>,
    /// Number of distinct nodes used as joints by the model's skins.
    pub joints: usize,
    /// URL path of the `<stem>.kloub.json` sidecar beside the model (example poses, joint
    /// settings), which the viewer's Samples menu loads with it; absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sidecar: Option<String>,
    /// Why the model did not import; absent when it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Builds the index of every `.glb`/`.gltf` under `root`, sorted by path.
pub fn build(root: &Root) -> Vec<AssetEntry> {
    let all = root.list();
    all.iter().filter(|p| is_model(p)).map(|p| entry(root, &all, p)).collect()
}

fn is_model(path: &str) -> bool {
    let ext = path.rsplit_once('.').map(|(_, e)| e).unwrap_or_default();
    ext.eq_ignore_ascii_case("glb") || ext.eq_ignore_ascii_case("gltf")
}

/// `/assets/<path>` with every segment percent-encoded.
pub fn url_of(path: &str) -> String {
    let encoded: Vec<String> = path.split('/').map(percent_encode_segment).collect();
    format!("/assets/{}", encoded.join("/"))
}

/// Folder part of a relative path (`""` at the root).
fn folder(path: &str) -> &str {
    path.rsplit_once('/').map_or("", |(dir, _)| dir)
}

fn entry(root: &Root, all: &[String], path: &str) -> AssetEntry {
    let file_name = path.rsplit('/').next().unwrap_or(path);
    let stem = file_name.rsplit_once('.').map_or(file_name, |(s, _)| s).to_owned();
    let options = ImportOptions::default();
    let resolver =
        LibraryResolver { root, folder: folder(path), budget: options.budget_bytes, loaded: RefCell::new(Vec::new()) };
    let licence = licence(root, all, path, &stem);
    let mut entry = AssetEntry {
        attribution: licence.as_deref().and_then(attribution),
        licence,
        default: path == super::DEFAULT_MODEL,
        name: stem,
        url: url_of(path),
        files: Vec::new(),
        size: 0,
        clips: Vec::new(),
        joints: 0,
        sidecar: None,
        error: None,
    };
    let dir = folder(path);
    let sidecar =
        if dir.is_empty() { format!("{}.kloub.json", entry.name) } else { format!("{dir}/{}.kloub.json", entry.name) };
    if all.contains(&sidecar) {
        entry.sidecar = Some(url_of(&sidecar));
    }
    let bytes = match root.read(path, options.budget_bytes) {
        Ok(b) => b,
        Err(e) => {
            entry.error = Some(format!("cannot read: {e}"));
            return entry;
        }
    };
    match kloub_core::import(&bytes, &resolver, &options) {
        Ok(imported) => {
            let asset = imported.asset;
            entry.clips = (asset.clips.iter().enumerate()).map(|(i, c)| c.display_name(i)).collect();
            let mut joints: Vec<u32> = (asset.skins.iter()).flat_map(|s| s.joints.iter().copied()).collect();
            joints.sort_unstable();
            joints.dedup();
            entry.joints = joints.len();
        }
        Err(e) => entry.error = Some(e.to_string()),
    }
    entry.files.push(entry.url.clone());
    entry.size = bytes.len() as u64;
    for (file, len) in resolver.loaded.into_inner() {
        entry.files.push(url_of(&file));
        entry.size += len;
    }
    entry
}

/// Resolves a model's external URIs to library files in its folder or below (the policy of
/// `kloub pose`), remembering which files it loaded.
struct LibraryResolver<'a> {
    root: &'a Root,
    folder: &'a str,
    budget: u64,
    loaded: RefCell<Vec<(String, u64)>>,
}

impl Resolver for LibraryResolver<'_> {
    fn resolve(&self, uri: &str) -> Result<Vec<u8>, String> {
        if kloub_core::import::is_web_uri(uri) {
            return Err(crate::pose::WEB_URI.to_owned());
        }
        let decoded = paths::percent_decode(uri).ok_or("refused: invalid percent-encoding")?;
        let segments =
            paths::safe_segments(&decoded).map_err(|_| "refused: the uri leaves the file's folder".to_owned())?;
        let rel =
            if self.folder.is_empty() { segments.join("/") } else { format!("{}/{}", self.folder, segments.join("/")) };
        let bytes = self.root.read(&rel, self.budget)?;
        let mut loaded = self.loaded.borrow_mut();
        if !loaded.iter().any(|(f, _)| *f == rel) {
            loaded.push((rel, bytes.len() as u64));
        }
        Ok(bytes)
    }
}

/// The licence of the model at `path` (rules on [`AssetEntry::licence`]); `all` lists the library.
fn licence(root: &Root, all: &[String], path: &str, stem: &str) -> Option<String> {
    let mut dir = folder(path);
    loop {
        let join = |name: &str| {
            if dir.is_empty() { name.to_owned() } else { format!("{dir}/{name}") }
        };
        let candidates =
            [join(&format!("{stem}.LICENSE.md")), join("LICENSE.md"), join("LICENSE"), join("LICENSE.txt")];
        for candidate in &candidates {
            if all.contains(candidate)
                && let Ok(bytes) = root.read(candidate, 1 << 20)
            {
                return Some(truncate(String::from_utf8_lossy(&bytes).trim()));
            }
        }
        let readme = join("README.md");
        if all.contains(&readme)
            && let Ok(bytes) = root.read(&readme, 1 << 20)
            && let Some(line) = String::from_utf8_lossy(&bytes).lines().find(|l| {
                let l = l.to_ascii_lowercase();
                ["licen", "copyright", "©", "&copy;"].iter().any(|k| l.contains(k))
            })
        {
            return Some(truncate(line.trim()));
        }
        if dir.is_empty() {
            return None;
        }
        dir = folder(dir);
    }
}

/// Longest attribution line, in bytes (cut at a character boundary beyond it).
const MAX_ATTRIBUTION_BYTES: usize = 400;

/// The first paragraph of a licence text that is not a Markdown heading, as one line.
fn attribution(licence: &str) -> Option<String> {
    let paragraph = licence
        .split("\n\n")
        .map(|p| p.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" "))
        .find(|p| !p.is_empty() && !p.starts_with('#'))?;
    if paragraph.len() <= MAX_ATTRIBUTION_BYTES {
        return Some(paragraph);
    }
    let mut end = MAX_ATTRIBUTION_BYTES;
    while !paragraph.is_char_boundary(end) {
        end -= 1;
    }
    Some(format!("{}…", &paragraph[..end]))
}

fn truncate(text: &str) -> String {
    if text.len() <= MAX_LICENCE_BYTES {
        return text.to_owned();
    }
    let mut end = MAX_LICENCE_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}…", &text[..end])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::serve::files::MemoryDir;
    use bytes::Bytes;

    fn library(files: &[(&str, &[u8])]) -> Root {
        Root::Memory(MemoryDir::new(files.iter().map(|(p, b)| ((*p).to_owned(), Bytes::copy_from_slice(b)))))
    }

    /// A minimal .gltf: one external buffer, two skins sharing a joint, a named and an unnamed clip.
    const SKINNED_GLTF: &str = r#"{
      "asset": {"version": "2.0"},
      "buffers": [{"uri": "data%20file.bin", "byteLength": 16}],
      "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 4}, {"buffer": 0, "byteOffset": 4, "byteLength": 12}],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 1, "type": "SCALAR", "min": [0], "max": [0]},
        {"bufferView": 1, "componentType": 5126, "count": 1, "type": "VEC3"}
      ],
      "nodes": [{"name": "root", "children": [1]}, {"name": "bone"}],
      "skins": [{"joints": [0, 1]}, {"joints": [1]}],
      "animations": [{"name": "Wave", "samplers": [{"input": 0, "output": 1}],
                      "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]},
                     {"samplers": [{"input": 0, "output": 1}],
                      "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}],
      "scenes": [{"nodes": [0]}], "scene": 0
    }"#;

    #[test]
    fn lists_files_size_licence_clips_joints_and_errors() {
        let root = library(&[
            ("LICENSE.md", b"Library licence"),
            ("men/Man.gltf", SKINNED_GLTF.as_bytes()),
            ("men/data file.bin", &[0u8; 16]),
            ("men/README.md", b"# Man\n\nSome text\n(c) Copyright 2020 Someone\n"),
            ("men/Man.kloub.json", b"{}"),
            ("Fox.glb", b"glTF not really"),
            ("Fox.LICENSE.md", b"  CC0  \n"),
            ("Fox.gltf.txt", b"not a model"),
        ]);
        let index = build(&root);
        assert_eq!(index.len(), 2, "{index:?}");
        let fox = &index[0];
        assert_eq!(fox.name, "Fox");
        assert_eq!(fox.url, "/assets/Fox.glb");
        assert_eq!(fox.files, vec!["/assets/Fox.glb"]);
        assert_eq!(fox.size, 15);
        assert_eq!(fox.licence.as_deref(), Some("CC0"));
        assert_eq!(fox.attribution.as_deref(), Some("CC0"));
        assert!(fox.default, "Fox.glb at the library's root is what /models/default.glb serves");
        assert!(!index[1].default);
        assert!(fox.error.is_some(), "a broken model is listed with its error");
        assert!(fox.clips.is_empty());

        let man = &index[1];
        assert_eq!(man.error, None, "{man:?}");
        assert_eq!(man.url, "/assets/men/Man.gltf");
        assert_eq!(man.files, vec!["/assets/men/Man.gltf", "/assets/men/data%20file.bin"]);
        assert_eq!(man.size, SKINNED_GLTF.len() as u64 + 16);
        assert_eq!(man.clips, vec!["Wave", "clip 1"]);
        assert_eq!(man.joints, 2, "distinct joint nodes");
        assert_eq!(man.sidecar.as_deref(), Some("/assets/men/Man.kloub.json"), "the sidecar beside it");
        assert_eq!(fox.sidecar, None);
        assert_eq!(
            man.licence.as_deref(),
            Some("(c) Copyright 2020 Someone"),
            "README line of the nearest folder before the library's LICENSE.md"
        );

        let json = serde_json::to_value(fox).expect("serializes");
        assert!(json.get("error").is_some());
        let json = serde_json::to_value(man).expect("serializes");
        assert!(json.get("error").is_none(), "no error key when it imported");
    }

    #[test]
    fn uris_leaving_the_folder_are_refused() {
        let escaping = SKINNED_GLTF.replace("data%20file.bin", "../data%20file.bin");
        let root = library(&[("men/Man.gltf", escaping.as_bytes()), ("data file.bin", &[0u8; 16])]);
        let index = build(&root);
        let error = index[0].error.as_deref().unwrap_or_default();
        // The importer refuses a `..` URI itself, before asking the resolver (which would too).
        assert!(error.contains("/buffers/0/uri") && error.contains("outside the folder"), "{error}");
        assert_eq!(index[0].files, vec!["/assets/men/Man.gltf"]);
        assert_eq!(index[0].licence, None);
    }

    #[test]
    fn attribution_is_the_first_paragraph_after_the_headings() {
        let text = "# Fox.glb — licence\n\n## Credits\n\nLow-poly fox by A (CC0).\n  Rigging by B.\n\nMore text.";
        assert_eq!(attribution(text).as_deref(), Some("Low-poly fox by A (CC0). Rigging by B."));
        assert_eq!(attribution("# only a heading\n"), None);
        assert_eq!(attribution("one line"), Some("one line".to_owned()));
        let long = attribution(&"é".repeat(MAX_ATTRIBUTION_BYTES)).unwrap_or_default();
        assert!(long.ends_with('…') && long.len() <= MAX_ATTRIBUTION_BYTES + '…'.len_utf8());
    }

    #[test]
    fn the_default_model_is_marked() {
        let root = library(&[("Fox.glb", b"x"), ("men/Fox.glb", b"x")]);
        let index = build(&root);
        let defaults: Vec<&str> = index.iter().filter(|e| e.default).map(|e| e.url.as_str()).collect();
        assert_eq!(defaults, ["/assets/Fox.glb"]);
    }

    #[test]
    fn long_licences_are_cut_at_a_character_boundary() {
        let text = "é".repeat(MAX_LICENCE_BYTES);
        let cut = truncate(&text);
        assert!(cut.len() <= MAX_LICENCE_BYTES + '…'.len_utf8());
        assert!(cut.ends_with('…'));
    }

    #[test]
    fn a_missing_library_gives_an_empty_index() {
        assert!(build(&Root::Missing).is_empty());
    }
}
