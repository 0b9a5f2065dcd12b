//! The `/api/assets` index: every `.glb`/`.gltf` under the asset folder, built once at start-up.

use crate::paths::{percent_encode_segment, resolve_decoded};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Folders deeper than this below the asset root are not scanned.
const MAX_DEPTH: usize = 16;
/// At most this many entries are listed.
const MAX_ENTRIES: usize = 10_000;

/// One model in the asset library.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct AssetEntry {
    /// File name without extension.
    pub name: String,
    /// URL path under which `kloub serve` serves the file (`/assets/...`, percent-encoded).
    pub url: String,
    /// File size in bytes.
    pub size: u64,
}

/// Scans `root` (canonical) recursively for `.glb`/`.gltf` files, sorted by URL.
/// Only files that the `/assets/` route would serve are listed (dot-files, odd names and
/// symlinks leading outside the root are skipped); unreadable folders are skipped with a warning.
pub fn scan(root: &Path) -> Vec<AssetEntry> {
    let mut out = Vec::new();
    walk(root, root, 0, &mut out);
    out.sort_by(|a, b| a.url.cmp(&b.url));
    out
}

fn walk(root: &Path, dir: &Path, depth: usize, out: &mut Vec<AssetEntry>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) => {
            log::warn!("asset index: cannot read a folder: {e}");
            return;
        }
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        if out.len() >= MAX_ENTRIES {
            log::warn!("asset index: stopped at {MAX_ENTRIES} entries");
            return;
        }
        let Ok(rel) = path.strip_prefix(root) else {
            continue;
        };
        let Some(rel) = rel
            .to_str()
            .map(|r| r.replace(std::path::MAIN_SEPARATOR, "/"))
        else {
            continue;
        };
        if path.is_dir() {
            // Refuse symlinked folders leading outside the root (and any unsafe name).
            let inside = path.canonicalize().is_ok_and(|c| c.starts_with(root));
            if inside && depth < MAX_DEPTH && crate::paths::safe_segments(&rel).is_ok() {
                walk(root, &path, depth + 1, out);
            }
            continue;
        }
        let is_model = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"));
        if !is_model {
            continue;
        }
        let Ok(file) = resolve_decoded(root, &rel) else {
            continue;
        };
        let Ok(meta) = file.metadata() else { continue };
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_owned();
        let url = rel
            .split('/')
            .map(percent_encode_segment)
            .collect::<Vec<_>>()
            .join("/");
        out.push(AssetEntry {
            name,
            url: format!("/assets/{url}"),
            size: meta.len(),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_models_recursively_with_sizes_and_encoded_urls() {
        let base = std::env::temp_dir().join(format!("kloub-index-{}", std::process::id()));
        let root = base.join("assets");
        std::fs::create_dir_all(root.join("sub dir/deeper")).expect("temp dir is writable");
        std::fs::create_dir_all(root.join(".hidden")).expect("temp dir is writable");
        std::fs::write(root.join("Fox.glb"), [0u8; 12]).expect("write");
        std::fs::write(root.join("Fox.LICENSE.md"), "licence").expect("write");
        std::fs::write(root.join("sub dir/deeper/Man.GLTF"), "{}").expect("write");
        std::fs::write(root.join("sub dir/Man.bin"), "b").expect("write");
        std::fs::write(root.join(".hidden/Secret.glb"), "s").expect("write");
        std::fs::write(base.join("Outside.glb"), "o").expect("write");
        #[cfg(unix)]
        std::os::unix::fs::symlink(&base, root.join("up")).expect("symlink");
        let root = root.canonicalize().expect("exists");

        let index = scan(&root);
        assert_eq!(
            index,
            vec![
                AssetEntry {
                    name: "Fox".into(),
                    url: "/assets/Fox.glb".into(),
                    size: 12
                },
                AssetEntry {
                    name: "Man".into(),
                    url: "/assets/sub%20dir/deeper/Man.GLTF".into(),
                    size: 2
                },
            ]
        );
        let json = serde_json::to_string(&index[0]).expect("serializes");
        assert_eq!(json, r#"{"name":"Fox","url":"/assets/Fox.glb","size":12}"#);
        std::fs::remove_dir_all(&base).expect("cleanup");
    }

    #[test]
    fn missing_root_gives_an_empty_index() {
        assert!(scan(Path::new("/nonexistent/kloub/assets")).is_empty());
    }
}
