//! The sample library of the Samples menu: the models a server offers (`kloub serve` lists them
//! at `/api/assets`), each with the credit its licence asks for. The page hands the list to the
//! viewer (`<kloub-viewer>.samples`); a click loads the model's URL like `src` does, and while a
//! sample is shown the panel credits it under the model's name.

use serde_json::Value;

/// Most entries kept from one list (the element refuses a longer one; this cut is the last guard).
pub const MAX_SAMPLES: usize = 1024;

/// Longest name, attribution or licence kept, in bytes (cut at a character boundary).
const MAX_TEXT_BYTES: usize = 8 * 1024;

/// One model of the sample library.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleEntry {
    /// The name shown in the menu (the file name without extension).
    pub name: String,
    /// Where the model is fetched from.
    pub url: String,
    /// One line crediting the model (empty when the server gave none).
    pub attribution: String,
    /// The licence text (empty when the server gave none).
    pub licence: String,
    /// Clip count, for the menu's hover text.
    pub clips: usize,
    /// Joint count, for the menu's hover text.
    pub joints: usize,
    /// Total download size in bytes.
    pub size: u64,
    /// Whether this is the model the page opens with (`/models/default.glb`).
    pub default: bool,
    /// The URL of its `<model>.kloub.json` sidecar (example poses, joint settings), loaded
    /// with it; empty for none.
    pub sidecar: String,
}

impl SampleEntry {
    /// The menu's hover text: size, clips, joints and the credit.
    pub fn summary(&self) -> String {
        let mut parts = vec![format!("{:.1} MB", self.size as f64 / 1e6)];
        if self.clips > 0 {
            parts.push(format!("{} clip{}", self.clips, if self.clips == 1 { "" } else { "s" }));
        }
        if self.joints > 0 {
            parts.push(format!("{} joints", self.joints));
        }
        let mut text = parts.join(" · ");
        if !self.sidecar.is_empty() {
            text.push_str("\nWith a sidecar: example poses for SJB by example, joint settings");
        }
        if !self.attribution.is_empty() {
            text.push_str("\n\n");
            text.push_str(&self.attribution);
        }
        text
    }

    /// The URL the Samples menu loads: the model's, with `#sidecar=` and the sidecar's when it
    /// has one ([`crate::load::split_sidecar`]).
    pub fn load_url(&self) -> String {
        if self.sidecar.is_empty() { self.url.clone() } else { format!("{}#sidecar={}", self.url, self.sidecar) }
    }

    /// Whether this entry is what a model loaded from `url` shows.
    pub fn is_shown_from(&self, url: &str) -> bool {
        let (url, _) = crate::load::split_sidecar(url);
        let path = url.split(['?', '#']).next().unwrap_or(url);
        url == self.url || (self.default && path.ends_with("/models/default.glb"))
    }
}

/// Parses the library's JSON: an array of `{name, url, attribution?, licence?, clips?, joints?,
/// size?, default?, sidecar?}` (the shape of `kloub serve`'s `/api/assets`). Entries without a name or
/// URL and entries the server could not import (`error`) are left out; anything that is not
/// such an array is an error naming what was wrong.
pub fn parse(json: &str) -> Result<Vec<SampleEntry>, String> {
    let value: Value = serde_json::from_str(json).map_err(|e| format!("samples: not JSON: {e}"))?;
    let Value::Array(items) = value else {
        return Err("samples: expected an array of {name, url, …}".to_owned());
    };
    let text = |item: &Value, key: &str| item.get(key).and_then(Value::as_str).map(cut).unwrap_or_default();
    let count = |item: &Value, key: &str| match item.get(key) {
        Some(Value::Array(a)) => a.len() as u64,
        Some(v) => v.as_u64().unwrap_or(0),
        None => 0,
    };
    let mut entries = Vec::new();
    for item in items.iter().take(MAX_SAMPLES) {
        if !item.is_object() || item.get("error").is_some_and(|e| !e.is_null()) {
            continue;
        }
        let (name, url) = (text(item, "name"), text(item, "url"));
        if name.is_empty() || url.is_empty() {
            continue;
        }
        entries.push(SampleEntry {
            name,
            url,
            attribution: text(item, "attribution"),
            licence: text(item, "licence"),
            clips: usize::try_from(count(item, "clips")).unwrap_or(usize::MAX),
            joints: usize::try_from(count(item, "joints")).unwrap_or(usize::MAX),
            size: count(item, "size"),
            default: item.get("default").and_then(Value::as_bool).unwrap_or(false),
            sidecar: text(item, "sidecar"),
        });
    }
    Ok(entries)
}

fn cut(text: &str) -> String {
    if text.len() <= MAX_TEXT_BYTES {
        return text.to_owned();
    }
    let mut end = MAX_TEXT_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}…", &text[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    const INDEX: &str = r##"[
      {"name": "Fox", "url": "/assets/Fox.glb", "files": ["/assets/Fox.glb"], "size": 162852,
       "licence": "# Fox\n\nLow-poly fox", "attribution": "Low-poly fox by PixelMannen (CC0).",
       "default": true, "clips": ["Survey", "Walk", "Run"], "joints": 24},
      {"name": "Broken", "url": "/assets/Broken.glb", "error": "not glTF"},
      {"name": "", "url": "/assets/NoName.glb"},
      "not an object",
      {"name": "Man", "url": "/assets/men/Man.glb", "clips": ["Walk"], "licence": null,
       "sidecar": "/assets/men/Man.kloub.json"}
    ]"##;

    #[test]
    fn parses_the_server_index_and_skips_what_cannot_be_shown() {
        let entries = parse(INDEX).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = entries.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(names, ["Fox", "Man"]);
        let fox = &entries[0];
        assert_eq!((fox.clips, fox.joints, fox.size, fox.default), (3, 24, 162_852, true));
        assert_eq!(fox.attribution, "Low-poly fox by PixelMannen (CC0).");
        assert!(fox.summary().starts_with("0.2 MB · 3 clips · 24 joints\n\nLow-poly fox"), "{}", fox.summary());
        let man = &entries[1];
        assert_eq!((man.licence.as_str(), man.default, man.clips), ("", false, 1));
        assert!(man.summary().starts_with("0.0 MB · 1 clip\nWith a sidecar"), "{}", man.summary());
        assert_eq!(man.load_url(), "/assets/men/Man.glb#sidecar=/assets/men/Man.kloub.json");
        assert!(man.is_shown_from(&man.load_url()));
        assert_eq!(fox.load_url(), "/assets/Fox.glb");
    }

    #[test]
    fn anything_but_an_array_is_an_error() {
        assert!(parse("{}").is_err_and(|e| e.contains("array")));
        assert!(parse("[").is_err_and(|e| e.contains("not JSON")));
        assert_eq!(parse("[]"), Ok(Vec::new()));
    }

    #[test]
    fn long_lists_and_texts_are_cut() {
        let one = r#"{"name": "M", "url": "/m.glb"}"#;
        let list = format!("[{}]", vec![one; MAX_SAMPLES + 5].join(","));
        assert_eq!(parse(&list).map(|e| e.len()), Ok(MAX_SAMPLES));
        let long = format!(r#"[{{"name": "M", "url": "/m.glb", "licence": "{}"}}]"#, "é".repeat(MAX_TEXT_BYTES));
        let licence = parse(&long).map(|e| e[0].licence.clone()).unwrap_or_default();
        assert!(licence.ends_with('…') && licence.len() <= MAX_TEXT_BYTES + '…'.len_utf8());
    }

    #[test]
    fn the_shown_sample_is_found_by_its_url_or_as_the_default() {
        let entries = parse(INDEX).unwrap_or_else(|e| panic!("{e}"));
        assert!(entries[0].is_shown_from("/assets/Fox.glb"));
        assert!(entries[0].is_shown_from("/models/default.glb"));
        assert!(entries[0].is_shown_from("http://127.0.0.1:8080/models/default.glb?v=2"));
        assert!(!entries[1].is_shown_from("/models/default.glb"), "only the default entry");
        assert!(entries[1].is_shown_from("/assets/men/Man.glb"));
        assert!(!entries[1].is_shown_from("/assets/men/Man.gltf"));
    }
}
