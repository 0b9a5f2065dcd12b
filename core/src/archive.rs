//! Zip archives as models are downloaded: a glTF folder (`.gltf` + `.bin` + textures), or a
//! few models, zipped (asset stores and Sketchfab deliver them so). Read in memory, natively and
//! on wasm32 alike, with the `zip` crate (stored and deflate entries).
//!
//! Bounded before anything is inflated: the entry count and the sum of the sizes the archive
//! *declares* are checked against [`ArchiveLimits`] (a small file declaring gigabytes is
//! refused), and each entry is read no further than its declared size (an entry that inflates
//! past it is refused). Names that are absolute or climb out with `..` are left out with a
//! note, as are macOS's `__MACOSX/` resource forks; nothing is ever written anywhere.
//!
//! [`read_zip`] needs the `codecs` feature; a build without it opens archives through
//! [`crate::codecs::Codecs::unzip`].

#[cfg(feature = "codecs")]
use std::io::Read;

/// Limits on what an archive may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ArchiveLimits {
    /// Most entries (files and folders) in the central directory.
    pub max_entries: usize,
    /// Most bytes all files together may inflate to.
    pub max_bytes: u64,
}

impl Default for ArchiveLimits {
    /// 10,000 entries and the import budget (512 MiB).
    fn default() -> Self {
        Self { max_entries: 10_000, max_bytes: crate::ImportOptions::default().budget_bytes }
    }
}

/// One file of an archive.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArchiveEntry {
    /// Its path inside the archive, `/`-separated, without `./` or a leading `/`.
    pub path: String,
    /// Its inflated contents.
    pub bytes: Vec<u8>,
}

/// The files of an archive, and what was left out.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Archive {
    /// The files, in archive order (folders are implied by the paths).
    pub entries: Vec<ArchiveEntry>,
    /// One note per entry left out (unsafe name, resource fork), for the warnings list.
    pub skipped: Vec<String>,
}

impl Archive {
    /// Paths of the `.glb`/`.gltf` models inside, in archive order.
    pub fn models(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.path.as_str()).filter(|p| is_model_path(p)).collect()
    }
}

/// Whether `path` names a `.glb` or `.gltf` file.
pub fn is_model_path(path: &str) -> bool {
    let lower = path.to_ascii_lowercase();
    lower.ends_with(".glb") || lower.ends_with(".gltf")
}

/// Whether `bytes` start like a zip archive (a local file header, or an empty archive's end
/// record).
pub fn is_zip(bytes: &[u8]) -> bool {
    bytes.starts_with(b"PK\x03\x04") || bytes.starts_with(b"PK\x05\x06")
}

/// Reads every file of the zip archive `bytes`.
#[cfg(feature = "codecs")]
///
/// # Errors
/// A message a user can act on: not a zip archive, too many entries, more declared bytes than
/// `limits` allow (nothing is inflated then), an entry compressed with a method other than
/// stored or deflate (naming it), an encrypted entry, or an entry whose data is corrupt or
/// inflates past its declared size.
pub fn read_zip(bytes: &[u8], limits: &ArchiveLimits) -> Result<Archive, String> {
    let mut zip =
        zip::ZipArchive::new(std::io::Cursor::new(bytes)).map_err(|e| format!("not a readable zip archive: {e}"))?;
    if zip.len() > limits.max_entries {
        return Err(format!("the archive has {} entries: at most {} are read", zip.len(), limits.max_entries));
    }
    // Declared sizes first: a bomb is refused before a byte is inflated.
    let mut declared: u64 = 0;
    for i in 0..zip.len() {
        let file = zip.by_index_raw(i).map_err(|e| format!("entry {i}: {e}"))?;
        if file.is_dir() {
            continue;
        }
        declared = declared.saturating_add(file.size());
        if declared > limits.max_bytes {
            return Err(format!(
                "the archive declares more than {} bytes uncompressed, over the {}-byte import budget: refused \
                 without inflating it",
                declared, limits.max_bytes
            ));
        }
    }
    let mut archive = Archive::default();
    for i in 0..zip.len() {
        let (raw_name, is_dir, size, method) = {
            let file = zip.by_index_raw(i).map_err(|e| format!("entry {i}: {e}"))?;
            let name = file.name().map_err(|e| format!("entry {i}: {e}"))?.into_owned();
            (name, file.is_dir(), file.size(), file.compression())
        };
        if is_dir {
            continue;
        }
        let Some(path) = safe_path(&raw_name) else {
            archive.skipped.push(format!("{raw_name:?}: left out of the archive (an absolute path or one with ..)"));
            continue;
        };
        if path.starts_with("__MACOSX/") || path.rsplit('/').next().is_some_and(|n| n.starts_with("._")) {
            archive.skipped.push(format!("{path}: left out of the archive (a macOS resource fork)"));
            continue;
        }
        if !matches!(method, zip::CompressionMethod::Stored | zip::CompressionMethod::Deflated) {
            return Err(format!("{path}: compressed with {method}, which Kloub cannot read (only stored and deflate)"));
        }
        let file = zip.by_index(i).map_err(|e| match e {
            zip::result::ZipError::UnsupportedArchive(what) => format!("{path}: {what}"),
            other => format!("{path}: {other}"),
        })?;
        let capacity = usize::try_from(size.min(limits.max_bytes)).unwrap_or(0);
        let mut data = Vec::with_capacity(capacity);
        file.take(size.saturating_add(1))
            .read_to_end(&mut data)
            .map_err(|e| format!("{path}: corrupt archive data ({e})"))?;
        if data.len() as u64 != size {
            return Err(format!("{path}: inflates to {} bytes, not the {size} its header declares", data.len()));
        }
        archive.entries.push(ArchiveEntry { path, bytes: data });
    }
    Ok(archive)
}

#[cfg(feature = "codecs")]
/// `name` as a relative `/`-separated path, or `None` when it is absolute, has a drive letter or
/// climbs out of the archive with `..`.
fn safe_path(name: &str) -> Option<String> {
    let unified = name.replace('\\', "/");
    if unified.starts_with('/') || unified.as_bytes().get(1) == Some(&b':') {
        return None;
    }
    let mut parts = Vec::new();
    for part in unified.split('/') {
        match part {
            "" | "." => {}
            ".." => return None,
            p => parts.push(p),
        }
    }
    (!parts.is_empty()).then(|| parts.join("/"))
}

#[cfg(all(test, feature = "codecs"))]
mod tests {
    use super::*;
    use std::io::Write;

    fn zip_of(files: &[(&str, &[u8], bool)]) -> Vec<u8> {
        let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        for (name, bytes, deflate) in files {
            let method = if *deflate { zip::CompressionMethod::Deflated } else { zip::CompressionMethod::Stored };
            let options = zip::write::SimpleFileOptions::default().compression_method(method);
            out.start_file(*name, options).expect("start");
            out.write_all(bytes).expect("write");
        }
        out.finish().expect("finish").into_inner()
    }

    #[test]
    fn reads_stored_and_deflated_entries_with_their_folders() {
        let bytes = zip_of(&[
            ("Man/Man.gltf", b"{}", true),
            ("Man/data.bin", &[7u8; 1000], true),
            ("./Man/tex/skin.png", b"png", false),
        ]);
        assert!(is_zip(&bytes));
        let archive = read_zip(&bytes, &ArchiveLimits::default()).expect("reads");
        let paths: Vec<&str> = archive.entries.iter().map(|e| e.path.as_str()).collect();
        assert_eq!(paths, ["Man/Man.gltf", "Man/data.bin", "Man/tex/skin.png"]);
        assert_eq!(archive.entries[1].bytes, vec![7u8; 1000]);
        assert_eq!(archive.models(), ["Man/Man.gltf"]);
        assert!(archive.skipped.is_empty());
    }

    #[test]
    fn names_that_climb_out_or_are_absolute_are_left_out_with_a_note() {
        let bytes = zip_of(&[
            ("../evil.glb", b"x", false),
            ("/etc/passwd", b"x", false),
            ("C:/boot.ini", b"x", false),
            ("a/../../b.bin", b"x", false),
            ("__MACOSX/Man/._Man.gltf", b"x", false),
            ("ok/Man.glb", b"glb", false),
        ]);
        let archive = read_zip(&bytes, &ArchiveLimits::default()).expect("reads");
        assert_eq!(archive.entries.len(), 1, "{archive:?}");
        assert_eq!(archive.entries[0].path, "ok/Man.glb");
        assert_eq!(archive.skipped.len(), 5, "{:?}", archive.skipped);
        assert!(archive.skipped[0].contains("../evil.glb") && archive.skipped[0].contains(".."));
        assert!(archive.skipped[4].contains("resource fork"));
    }

    #[test]
    fn a_bomb_is_refused_before_inflating() {
        // A megabyte of zeros deflates to about a kilobyte; a limit far below the declared size refuses it.
        let bytes = zip_of(&[("zeros.bin", &vec![0u8; 1 << 20], true)]);
        assert!(bytes.len() < 8 << 10, "{} bytes", bytes.len());
        let limits = ArchiveLimits { max_entries: 10, max_bytes: 64 << 10 };
        let err = read_zip(&bytes, &limits).expect_err("refused");
        assert!(err.contains("declares") && err.contains("budget") && err.contains("without inflating"), "{err}");
        let many = zip_of(&[("a", b"1", false), ("b", b"2", false), ("c", b"3", false)]);
        let err = read_zip(&many, &ArchiveLimits { max_entries: 2, max_bytes: 1 << 20 }).expect_err("refused");
        assert!(err.contains("3 entries"), "{err}");
    }

    #[test]
    fn a_header_lying_about_its_size_is_refused() {
        let mut bytes = zip_of(&[("big.bin", &[5u8; 4096], true)]);
        // Shrink the declared uncompressed size (in the central directory and the local header) to 16 bytes.
        let lie = 16u32.to_le_bytes();
        let mut patched = 0;
        for i in 0..bytes.len().saturating_sub(4) {
            if bytes[i..i + 4] == 4096u32.to_le_bytes() {
                bytes[i..i + 4].copy_from_slice(&lie);
                patched += 1;
            }
        }
        assert!(patched >= 2, "patched {patched} size fields");
        let err = read_zip(&bytes, &ArchiveLimits::default()).expect_err("refused");
        assert!(err.contains("big.bin"), "{err}");
    }

    #[test]
    fn unsupported_methods_name_themselves() {
        let mut bytes = zip_of(&[("a.bin", b"abc", false)]);
        // Method 14 (LZMA) in the local header (offset 8) and the central directory (offset 10 of its record).
        bytes[8] = 14;
        let cd = bytes.windows(4).position(|w| w == b"PK\x01\x02").expect("central directory");
        bytes[cd + 10] = 14;
        let err = read_zip(&bytes, &ArchiveLimits::default()).expect_err("refused");
        assert!(err.contains("a.bin") && err.contains("cannot read"), "{err}");
    }

    #[test]
    fn garbage_is_not_a_zip_and_never_panics() {
        assert!(!is_zip(b"glTF"));
        assert!(read_zip(b"PK\x03\x04 not really", &ArchiveLimits::default()).is_err());
        let good = zip_of(&[("a/b.gltf", b"{\"asset\":{}}", true), ("a/c.bin", &[1u8; 300], true)]);
        for cut in 0..good.len() {
            let _ = read_zip(&good[..cut], &ArchiveLimits::default());
        }
        for i in 0..good.len() {
            let mut flipped = good.clone();
            flipped[i] ^= 0x5a;
            let _ = read_zip(&flipped, &ArchiveLimits::default());
        }
    }
}
