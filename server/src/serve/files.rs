//! Where served files come from: a folder on disk ([`Source::Dir`]) or files held in memory
//! ([`Source::Memory`], e.g. the bundle embedded in the binary), behind one lookup with the
//! path policy of [`crate::paths`].
//!
//! A file may have precompressed siblings, `NAME.gz` and `NAME.br`; they become alternative
//! representations of `NAME` ([`Found`]). On disk a sibling older than `NAME` is ignored (stale).
//! Every representation has a strong ETag: a content hash for files in memory (computed once,
//! when the [`MemoryDir`] is built), size and modification time for files on disk.

use crate::paths::{self, Refusal};
use bytes::Bytes;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::UNIX_EPOCH;

/// A tree of files to serve.
#[derive(Clone, Debug)]
pub enum Source {
    /// A folder on disk, read on every request (a missing folder serves nothing).
    Dir(PathBuf),
    /// Files in memory.
    Memory(MemoryDir),
}

/// Files in memory by relative path (`a/b.glb`), each with its ETag. Cheap to clone.
#[derive(Clone, Debug, Default)]
pub struct MemoryDir {
    files: Arc<BTreeMap<String, MemoryFile>>,
}

#[derive(Debug)]
struct MemoryFile {
    bytes: Bytes,
    etag: String,
}

impl MemoryDir {
    /// Builds the set from `(relative path, bytes)` pairs, hashing every file once.
    /// Paths are `/`-separated and not percent-encoded; a path the policy of
    /// [`crate::paths::safe_segments`] refuses is dropped with a warning.
    pub fn new(files: impl IntoIterator<Item = (String, Bytes)>) -> Self {
        let mut map = BTreeMap::new();
        for (path, bytes) in files {
            match paths::safe_segments(&path) {
                Ok(segments) if !segments.is_empty() => {
                    let etag = content_etag(&bytes);
                    map.insert(segments.join("/"), MemoryFile { bytes, etag });
                }
                _ => log::warn!("in-memory file with an unsafe path skipped"),
            }
        }
        Self { files: Arc::new(map) }
    }

    /// [`MemoryDir::new`] over static data (the tables `build.rs` embeds), without copying.
    pub fn from_static(files: &'static [(&'static str, &'static [u8])]) -> Self {
        Self::new(files.iter().map(|(path, bytes)| ((*path).to_owned(), Bytes::from_static(bytes))))
    }

    /// Number of files (precompressed siblings included).
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether there are no files at all.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// The relative paths, sorted.
    pub fn paths(&self) -> impl Iterator<Item = &str> {
        self.files.keys().map(String::as_str)
    }

    /// The bytes of the file at relative path `path`, if any.
    pub fn get(&self, path: &str) -> Option<&Bytes> {
        self.files.get(path).map(|f| &f.bytes)
    }

    fn variant(&self, path: &str) -> Option<Variant> {
        self.files.get(path).map(|f| Variant {
            etag: f.etag.clone(),
            len: f.bytes.len() as u64,
            content: Content::Memory(f.bytes.clone()),
        })
    }
}

/// A strong ETag from the content: the first 128 bits of its SHA-256, quoted.
pub fn content_etag(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    let mut tag = String::with_capacity(34);
    tag.push('"');
    for b in &digest[..16] {
        let _ = write!(tag, "{b:02x}");
    }
    tag.push('"');
    tag
}

/// The bytes of one representation.
#[derive(Clone, Debug)]
pub enum Content {
    /// Held in memory.
    Memory(Bytes),
    /// A regular file on disk (canonical path).
    Disk(PathBuf),
}

/// One representation of a file: the file itself or a precompressed sibling.
#[derive(Clone, Debug)]
pub struct Variant {
    /// Strong ETag, quoted.
    pub etag: String,
    /// Length in bytes.
    pub len: u64,
    /// Where the bytes are.
    pub content: Content,
}

/// A file found by [`Root::lookup`], with its precompressed siblings.
#[derive(Clone, Debug)]
pub struct Found {
    /// Decoded relative path, `/`-separated (gives the MIME type and the cache rule).
    pub path: String,
    /// The file as stored.
    pub identity: Variant,
    /// `PATH.gz`, when present (and, on disk, not older than the file).
    pub gzip: Option<Variant>,
    /// `PATH.br`, likewise.
    pub br: Option<Variant>,
}

/// A [`Source`] opened for serving: folders canonicalized once.
#[derive(Clone, Debug)]
pub enum Root {
    /// A canonical folder.
    Dir(PathBuf),
    /// Files in memory.
    Memory(MemoryDir),
    /// Nothing to serve (the folder did not exist).
    Missing,
}

impl Root {
    /// Opens `source`; a folder that does not exist is logged as `what` and serves nothing.
    pub fn open(source: &Source, what: &str) -> Self {
        match source {
            Source::Memory(m) => Root::Memory(m.clone()),
            Source::Dir(dir) => match paths::canonical_root(dir) {
                Ok(c) if c.is_dir() => Root::Dir(c),
                _ => {
                    log::warn!("{what} {} is not a folder", dir.display());
                    Root::Missing
                }
            },
        }
    }

    /// Whether the file at decoded relative path `path` exists.
    pub fn has(&self, path: &str) -> bool {
        self.lookup_decoded(path).is_ok()
    }

    /// Finds the file at the percent-encoded relative path `encoded` (a URL path).
    /// Blocking on disk: call it off the async runtime for [`Root::Dir`].
    pub fn lookup(&self, encoded: &str) -> Result<Found, Refusal> {
        let decoded = paths::percent_decode(encoded).ok_or(Refusal::Unsafe)?;
        self.lookup_decoded(&decoded)
    }

    /// [`Root::lookup`] for an already decoded path.
    pub fn lookup_decoded(&self, decoded: &str) -> Result<Found, Refusal> {
        let segments = paths::safe_segments(decoded)?;
        if segments.is_empty() {
            return Err(Refusal::NotFound);
        }
        let key = segments.join("/");
        match self {
            Root::Missing => Err(Refusal::NotFound),
            Root::Memory(m) => {
                let identity = m.variant(&key).ok_or(Refusal::NotFound)?;
                Ok(Found {
                    gzip: m.variant(&format!("{key}.gz")),
                    br: m.variant(&format!("{key}.br")),
                    path: key,
                    identity,
                })
            }
            Root::Dir(root) => {
                let (identity, modified) = disk_variant(root, &key)?;
                let sibling = |ext: &str| {
                    disk_variant(root, &format!("{key}.{ext}")).ok().filter(|(_, m)| *m >= modified).map(|(v, _)| v)
                };
                Ok(Found { gzip: sibling("gz"), br: sibling("br"), path: key, identity })
            }
        }
    }

    /// All files under the root as decoded relative paths, sorted; only those
    /// [`Root::lookup_decoded`] would serve. On disk the walk is bounded in depth and count.
    pub fn list(&self) -> Vec<String> {
        match self {
            Root::Missing => Vec::new(),
            Root::Memory(m) => m.paths().map(str::to_owned).collect(),
            Root::Dir(root) => {
                let mut out = Vec::new();
                walk(root, root, 0, &mut out);
                out.sort();
                out
            }
        }
    }

    /// Reads the whole file at decoded relative path `path`, refusing files over `max_bytes`.
    pub fn read(&self, path: &str, max_bytes: u64) -> Result<Vec<u8>, String> {
        let found = self.lookup_decoded(path).map_err(|r| match r {
            Refusal::Unsafe => "refused: unsafe path".to_owned(),
            Refusal::NotFound => "no such file".to_owned(),
        })?;
        if found.identity.len > max_bytes {
            return Err(format!("{} bytes is over the {max_bytes}-byte budget", found.identity.len));
        }
        match found.identity.content {
            Content::Memory(b) => Ok(b.to_vec()),
            Content::Disk(p) => std::fs::read(p).map_err(|e| e.to_string()),
        }
    }
}

/// The file at the safe relative path `key` under the canonical `root`, with its mtime.
fn disk_variant(root: &Path, key: &str) -> Result<(Variant, u128), Refusal> {
    let path = paths::resolve_decoded(root, key)?;
    let meta = path.metadata().map_err(|_| Refusal::NotFound)?;
    let modified = meta.modified().ok().and_then(|t| t.duration_since(UNIX_EPOCH).ok()).map_or(0, |d| d.as_nanos());
    let variant =
        Variant { etag: format!("\"{:x}-{modified:x}\"", meta.len()), len: meta.len(), content: Content::Disk(path) };
    Ok((variant, modified))
}

/// Folders deeper than this below a root are not listed.
const MAX_DEPTH: usize = 16;
/// At most this many files are listed.
const MAX_FILES: usize = 100_000;

fn walk(root: &Path, dir: &Path, depth: usize, out: &mut Vec<String>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) => {
            log::warn!("cannot list a folder: {e}");
            return;
        }
    };
    for entry in entries.flatten() {
        if out.len() >= MAX_FILES {
            log::warn!("listing stopped at {MAX_FILES} files");
            return;
        }
        let path = entry.path();
        let Some(rel) =
            path.strip_prefix(root).ok().and_then(|r| r.to_str()).map(|r| r.replace(std::path::MAIN_SEPARATOR, "/"))
        else {
            continue;
        };
        if paths::safe_segments(&rel).is_err() {
            continue;
        }
        // Symlinked folders are followed only when they stay inside the root.
        let inside = path.canonicalize().is_ok_and(|c| c.starts_with(root));
        if path.is_dir() {
            if inside && depth < MAX_DEPTH {
                walk(root, &path, depth + 1, out);
            }
        } else if paths::resolve_decoded(root, &rel).is_ok() {
            out.push(rel);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mem(files: &[(&str, &[u8])]) -> Root {
        Root::Memory(MemoryDir::new(files.iter().map(|(p, b)| ((*p).to_owned(), Bytes::copy_from_slice(b)))))
    }

    #[test]
    fn memory_lookup_applies_the_path_policy_and_finds_siblings() {
        let root = mem(&[
            ("a.js", b"js"),
            ("a.js.gz", b"gz"),
            ("sub/b.wasm", b"wasm"),
            ("sub/b.wasm.br", b"br"),
            (".secret", b"no"),
            ("../up", b"no"),
        ]);
        let a = root.lookup("/a.js").expect("found");
        assert_eq!(a.path, "a.js");
        assert_eq!(a.identity.len, 2);
        assert!(a.gzip.is_some() && a.br.is_none());
        let b = root.lookup("sub//./b%2Ewasm").expect("found");
        assert_eq!(b.path, "sub/b.wasm");
        assert!(b.gzip.is_none() && b.br.is_some());
        assert_ne!(b.identity.etag, b.br.as_ref().expect("br").etag);
        assert_eq!(root.lookup("../up").err(), Some(Refusal::Unsafe));
        assert_eq!(root.lookup(".secret").err(), Some(Refusal::Unsafe));
        assert_eq!(root.lookup("sub").err(), Some(Refusal::NotFound));
        assert_eq!(root.lookup("").err(), Some(Refusal::NotFound));
        assert_eq!(root.list(), vec!["a.js", "a.js.gz", "sub/b.wasm", "sub/b.wasm.br"]);
        assert_eq!(root.read("sub/b.wasm", 4), Ok(b"wasm".to_vec()));
        assert!(root.read("sub/b.wasm", 3).is_err(), "over the budget");
    }

    #[test]
    fn content_etags_are_strong_hashes() {
        assert_eq!(content_etag(b""), "\"e3b0c44298fc1c149afbf4c8996fb924\"", "SHA-256 of nothing, first 128 bits");
        assert_ne!(content_etag(b"a"), content_etag(b"b"));
    }

    #[test]
    fn disk_siblings_older_than_the_file_are_ignored() {
        let dir = std::env::temp_dir().join(format!("kloub-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir is writable");
        std::fs::write(dir.join("a.js"), "js").expect("write");
        std::fs::write(dir.join("a.js.gz"), "old").expect("write");
        std::fs::write(dir.join("a.js.br"), "new").expect("write");
        let old = std::fs::File::options().write(true).open(dir.join("a.js.gz")).expect("open");
        old.set_modified(UNIX_EPOCH).expect("set mtime");
        let root = Root::open(&Source::Dir(dir.clone()), "test");
        let found = root.lookup("a.js").expect("found");
        assert!(found.gzip.is_none(), "stale .gz ignored");
        assert!(found.br.is_some());
        assert!(matches!(found.identity.content, Content::Disk(_)));
        assert!(matches!(Root::open(&Source::Dir(dir.join("nope")), "test"), Root::Missing));
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }
}
