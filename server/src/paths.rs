//! Safe mapping of untrusted relative paths (URL paths, glTF URIs) to files under a root folder.
//!
//! One policy for the server and for `kloub pose`'s external-file resolver:
//! 1. percent-decode once ([`percent_decode`]); invalid escapes or non-UTF-8 are refused;
//! 2. split on `/` and check every segment ([`safe_segments`]): `..`, dot-files, backslashes,
//!    NUL and control characters, `:` (drive letters, `c:`, NTFS streams), `%` left after decoding
//!    (double encoding), Windows device names and trailing dots/spaces are refused;
//!    empty and `.` segments are skipped;
//! 3. join the segments to the root, canonicalize, and require the result to stay under the
//!    canonical root ([`resolve_file`]), so a symlink that points outside is refused too.
//!
//! A refusal never says which rule fired, so error pages need not echo the path.

use std::path::{Path, PathBuf};

/// Why a path was not mapped to a file. Deliberately carries no path text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// The path breaks a rule of this module (traversal, odd characters, symlink escape...).
    Unsafe,
    /// The path is safe but names no regular file under the root.
    NotFound,
}

/// Decodes `%XX` escapes once. `None` when an escape is malformed or the bytes are not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hi = hex_value(*bytes.get(i + 1)?)?;
            let lo = hex_value(*bytes.get(i + 2)?)?;
            out.push(hi << 4 | lo);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

fn hex_value(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

/// Percent-encodes every byte of `segment` except RFC 3986 unreserved characters.
pub fn percent_encode_segment(segment: &str) -> String {
    let mut out = String::with_capacity(segment.len());
    for &b in segment.as_bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~') {
            out.push(char::from(b));
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// Windows device names, refused with or without an extension on every platform so a tree
/// served from Linux behaves the same when copied to Windows.
const RESERVED: [&str; 22] = [
    "con", "prn", "aux", "nul", "com1", "com2", "com3", "com4", "com5", "com6", "com7", "com8", "com9", "lpt1", "lpt2",
    "lpt3", "lpt4", "lpt5", "lpt6", "lpt7", "lpt8", "lpt9",
];

/// Splits an already decoded relative path into checked segments (rules in the module docs).
pub fn safe_segments(decoded: &str) -> Result<Vec<&str>, Refusal> {
    if decoded.contains('\\') || decoded.chars().any(char::is_control) {
        return Err(Refusal::Unsafe);
    }
    let mut out = Vec::new();
    for segment in decoded.split('/') {
        if segment.is_empty() || segment == "." {
            continue;
        }
        let stem = segment.split('.').next().unwrap_or(segment).to_ascii_lowercase();
        if segment.starts_with('.')
            || segment.contains([':', '%'])
            || segment.ends_with(['.', ' '])
            || RESERVED.contains(&stem.as_str())
        {
            return Err(Refusal::Unsafe);
        }
        out.push(segment);
    }
    Ok(out)
}

/// Canonicalizes a root folder once, so [`resolve_file`] can compare against it.
pub fn canonical_root(root: &Path) -> std::io::Result<PathBuf> {
    root.canonicalize()
}

/// Maps a percent-encoded relative path (a URL path or a glTF URI) to a regular file under
/// `root`, which must already be canonical ([`canonical_root`]).
pub fn resolve_file(root: &Path, encoded: &str) -> Result<PathBuf, Refusal> {
    let decoded = percent_decode(encoded).ok_or(Refusal::Unsafe)?;
    resolve_decoded(root, &decoded)
}

/// [`resolve_file`] for a path that is already percent-decoded.
pub fn resolve_decoded(root: &Path, decoded: &str) -> Result<PathBuf, Refusal> {
    let segments = safe_segments(decoded)?;
    if segments.is_empty() {
        return Err(Refusal::NotFound);
    }
    let joined = segments.iter().fold(root.to_path_buf(), |p, s| p.join(s));
    let canonical = joined.canonicalize().map_err(|_| Refusal::NotFound)?;
    if !canonical.starts_with(root) {
        return Err(Refusal::Unsafe);
    }
    match canonical.metadata() {
        Ok(m) if m.is_file() => Ok(canonical),
        _ => Err(Refusal::NotFound),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_once_and_refuses_bad_escapes() {
        assert_eq!(percent_decode("a%20b%2Fc").as_deref(), Some("a b/c"));
        assert_eq!(percent_decode("%252e").as_deref(), Some("%2e"));
        assert_eq!(percent_decode("%2"), None);
        assert_eq!(percent_decode("%zz"), None);
        assert_eq!(percent_decode("%ff"), None, "not UTF-8");
    }

    #[test]
    fn encodes_reserved_characters() {
        assert_eq!(percent_encode_segment("Fox.glb"), "Fox.glb");
        assert_eq!(percent_encode_segment("a b#?%"), "a%20b%23%3F%25");
    }

    #[test]
    fn traversal_vectors_are_refused() {
        let vectors = [
            "../etc/passwd",
            "a/../../b",
            "..",
            "%2e%2e/x",
            "%2E%2E%2Fx",
            "..%2fx",
            "..%5cx",
            "a\\..\\b",
            "%252e%252e/x",
            "c:/windows/win.ini",
            "/c:/x",
            "C%3A%5Cx",
            "x%00.html",
            "\0",
            ".env",
            ".git/config",
            "CON",
            "nul.txt",
            "Lpt1.glb",
            "file.",
            "file ",
            "a\nb",
            "%",
        ];
        let root = std::env::temp_dir();
        for v in vectors {
            assert_eq!(resolve_file(&root, v), Err(Refusal::Unsafe), "{v:?}");
        }
    }

    #[test]
    fn plain_paths_split_into_segments() {
        assert_eq!(safe_segments("/a//b/./c.glb"), Ok(vec!["a", "b", "c.glb"]));
        assert_eq!(safe_segments(""), Ok(vec![]));
        assert_eq!(safe_segments("console.log"), Ok(vec!["console.log"]));
    }

    #[test]
    fn files_resolve_under_root_and_symlinks_out_are_refused() {
        let base = std::env::temp_dir().join(format!("kloub-paths-{}", std::process::id()));
        let root = base.join("root");
        std::fs::create_dir_all(root.join("sub")).expect("temp dir is writable");
        std::fs::write(root.join("sub/a b.txt"), "x").expect("temp dir is writable");
        std::fs::write(base.join("secret.txt"), "s").expect("temp dir is writable");
        let root = canonical_root(&root).expect("root exists");

        let found = resolve_file(&root, "sub/a%20b.txt").expect("file exists");
        assert!(found.ends_with("sub/a b.txt"));
        assert_eq!(resolve_file(&root, "sub"), Err(Refusal::NotFound), "a folder is not a file");
        assert_eq!(resolve_file(&root, "missing.txt"), Err(Refusal::NotFound));
        assert_eq!(resolve_file(&root, "/"), Err(Refusal::NotFound));

        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(base.join("secret.txt"), root.join("out.txt")).expect("symlink");
            std::os::unix::fs::symlink(root.join("sub/a b.txt"), root.join("in.txt")).expect("symlink");
            assert_eq!(resolve_file(&root, "out.txt"), Err(Refusal::Unsafe));
            assert!(resolve_file(&root, "in.txt").is_ok(), "a symlink inside the root is fine");
        }
        std::fs::remove_dir_all(&base).expect("cleanup");
    }
}
