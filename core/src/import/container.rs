//! Bytes in: the GLB container, `data:` URIs, external files through the resolver,
//! buffers, and the byte budget.

use super::Resolver;
use super::json::{Obj, child, objects, opt_str, req_u64};
use crate::error::{ImportError, Warning};
use base64::Engine;
use std::borrow::Cow;
use std::fmt::Display;

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// The JSON text and optional BIN chunk of a document.
#[derive(Debug)]
pub(crate) struct Container<'a> {
    /// The JSON text.
    pub json: &'a [u8],
    /// The GLB BIN chunk, if any.
    pub bin: Option<&'a [u8]>,
}

/// Whether `bytes` start with the GLB magic.
pub(crate) fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(GLB_MAGIC)
}

fn glb_error(message: impl Into<String>) -> ImportError {
    ImportError::new("", format!("GLB container: {}", message.into()))
}

fn read_u32(bytes: &[u8], at: u64) -> Option<u32> {
    let at = usize::try_from(at).ok()?;
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB (or passes a .gltf JSON through), checking the header and chunk layout.
pub(crate) fn split<'a>(bytes: &'a [u8], warnings: &mut Vec<Warning>) -> Result<Container<'a>, ImportError> {
    if !is_glb(bytes) {
        let json = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        return Ok(Container { json, bin: None });
    }
    let total = bytes.len() as u64;
    let (Some(version), Some(length)) = (read_u32(bytes, 4), read_u32(bytes, 8)) else {
        return Err(glb_error(format!("truncated header ({total} bytes, a GLB header needs 12)")));
    };
    if version != 2 {
        return Err(glb_error(format!("version {version} is not supported (only glTF 2.0)")));
    }
    if u64::from(length) > total {
        return Err(glb_error(format!("header length {length} does not match the file size {total}")));
    }
    if u64::from(length) < total {
        warnings.push(Warning::new(
            "",
            format!("{} bytes after the GLB's declared length of {length} are ignored", total - u64::from(length)),
        ));
    }
    // In range: `length <= total`.
    let bytes = &bytes[..length as usize];
    let total = u64::from(length);
    let mut chunks = Vec::new();
    let mut at = 12u64;
    while at < total {
        // Padding after the last chunk, too short to be one.
        if total - at < 8 && !chunks.is_empty() {
            warnings.push(Warning::new("", format!("{} bytes after the last GLB chunk are ignored", total - at)));
            break;
        }
        let (Some(len), Some(kind)) = (read_u32(bytes, at), read_u32(bytes, at + 4)) else {
            return Err(glb_error(format!("truncated chunk header at byte {at}")));
        };
        let start = at + 8;
        let end = start + u64::from(len);
        if end > total {
            return Err(glb_error(format!(
                "chunk {} at byte {at} declares {len} bytes, but only {} remain",
                chunks.len(),
                total - start
            )));
        }
        if len % 4 != 0 {
            warnings.push(Warning::new("", format!("GLB chunk {} length {len} is not a multiple of 4", chunks.len())));
        }
        // In range of `bytes` (checked against `total` above), so the casts are lossless.
        chunks.push((kind, &bytes[start as usize..end as usize]));
        at = end;
    }
    let Some(&(CHUNK_JSON, json)) = chunks.first() else {
        return Err(glb_error("the first chunk must be JSON"));
    };
    let mut bin = None;
    for (i, &(kind, data)) in chunks.iter().enumerate().skip(1) {
        match kind {
            CHUNK_BIN if i == 1 => bin = Some(data),
            CHUNK_BIN => return Err(glb_error(format!("chunk {i}: only one BIN chunk is allowed, right after JSON"))),
            CHUNK_JSON => return Err(glb_error(format!("chunk {i}: a second JSON chunk"))),
            _ => {} // Unknown chunk types must be ignored.
        }
    }
    Ok(Container { json, bin })
}

/// Bytes the document may still allocate.
#[derive(Debug)]
pub(crate) struct Budget {
    limit: u64,
    left: u64,
}

impl Budget {
    /// A budget of `limit` bytes.
    pub fn new(limit: u64) -> Self {
        Self { limit, left: limit }
    }

    /// Takes `bytes` (None = overflowed arithmetic) for `what`, or refuses at `ptr` (both
    /// written out only for the refusal).
    pub fn take(
        &mut self,
        bytes: Option<u64>,
        ptr: &(impl Display + ?Sized),
        what: &(impl Display + ?Sized),
    ) -> Result<(), ImportError> {
        match bytes {
            Some(b) if b <= self.left => {
                self.left -= b;
                Ok(())
            }
            _ => Err(ImportError::new(
                ptr.to_string(),
                format!(
                    "{what} needs {} bytes, more than the {} bytes left of the import budget ({} bytes)",
                    bytes.map_or_else(|| "more than 2^64".to_string(), |b| b.to_string()),
                    self.left,
                    self.limit
                ),
            )),
        }
    }

    /// `count × size` bytes for `what`.
    pub fn take_items(
        &mut self,
        count: u64,
        size: u64,
        ptr: &(impl Display + ?Sized),
        what: &(impl Display + ?Sized),
    ) -> Result<(), ImportError> {
        self.take(count.checked_mul(size), ptr, what)
    }

    /// Bytes left.
    pub fn left(&self) -> u64 {
        self.left
    }
}

/// Decodes `%XX` escapes (invalid escapes are kept as they are), as the importer decodes a URI
/// before asking its [`super::Resolver`]; invalid UTF-8 becomes U+FFFD.
pub fn percent_decode(s: &str) -> String {
    String::from_utf8_lossy(&percent_decode_bytes(s)).into_owned()
}

/// Refuses an external URI that is not a plain relative path inside the document's folder.
pub(crate) fn check_relative_uri(uri: &str, ptr: &str) -> Result<(), ImportError> {
    let first_separator = uri.find(['/', '\\']).unwrap_or(uri.len());
    if uri[..first_separator].contains(':') {
        return Err(ImportError::new(ptr, format!("URI '{uri}': only relative paths and data: URIs are supported")));
    }
    let path = percent_decode(uri);
    if path.starts_with(['/', '\\']) {
        return Err(ImportError::new(ptr, format!("URI '{uri}' is an absolute path")));
    }
    let mut depth = 0i64;
    for segment in path.split(['/', '\\']) {
        match segment {
            "" | "." => {}
            ".." => {
                depth -= 1;
                if depth < 0 {
                    return Err(ImportError::new(
                        ptr,
                        format!("URI '{uri}' points outside the folder of the glTF file"),
                    ));
                }
            }
            _ => depth += 1,
        }
    }
    Ok(())
}

/// Decoded length of standard base64 text (padding and whitespace-free), or None if malformed.
fn base64_len(payload: &str) -> Option<u64> {
    let trimmed = payload.trim_end_matches('=');
    let n = trimmed.len() as u64;
    (n % 4 != 1).then_some(n / 4 * 3 + (n % 4).saturating_sub(1))
}

/// `%XX` escapes decoded to bytes (a `%` not followed by two hex digits stays as it is).
fn percent_decode_bytes(s: &str) -> Vec<u8> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        let hex = |at: usize| bytes.get(at).and_then(|&c| char::from(c).to_digit(16));
        match (b, hex(i + 1), hex(i + 2)) {
            // Two hex digits make a byte (at most 0xFF).
            (b'%', Some(high), Some(low)) => {
                out.push((high * 16 + low) as u8);
                i += 3;
            }
            _ => {
                out.push(b);
                i += 1;
            }
        }
    }
    out
}

/// Whether `uri` is an absolute `http:` or `https:` address (glTF allows them for buffers and
/// images; the viewer fetches them, the `kloub` tool does not).
pub fn is_web_uri(uri: &str) -> bool {
    let lower = uri.get(..8).unwrap_or(uri).to_ascii_lowercase();
    lower.starts_with("http://") || lower.starts_with("https://")
}

/// Bytes of a `data:` URI (base64, or percent-encoded per RFC 2397): checks the size against
/// the budget before decoding.
pub(crate) fn decode_data_uri(uri: &str, ptr: &str, budget: &mut Budget) -> Result<Vec<u8>, ImportError> {
    let rest = &uri[5..];
    let Some((header, payload)) = rest.split_once(',') else {
        return Err(ImportError::new(ptr, "data URI has no ',' before its data"));
    };
    if !header.ends_with(";base64") {
        // RFC 2397: without `;base64` the data is the URI's own characters, percent-encoded.
        let bytes = percent_decode_bytes(payload);
        budget.take(Some(bytes.len() as u64), ptr, "data URI")?;
        return Ok(bytes);
    }
    let Some(len) = base64_len(payload) else {
        return Err(ImportError::new(
            ptr,
            format!("data URI has an invalid base64 length ({} characters)", payload.len()),
        ));
    };
    budget.take(Some(len), ptr, "data URI")?;
    let engine = base64::engine::GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        base64::engine::GeneralPurposeConfig::new()
            .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
    );
    engine.decode(payload).map_err(|e| ImportError::new(ptr, format!("data URI is not valid base64: {e}")))
}

/// The bytes a `uri` names: decoded `data:` URI, or an external file through `resolver`.
pub(crate) fn load_uri<'a>(
    uri: &str,
    ptr: &str,
    resolver: &dyn Resolver,
    budget: &mut Budget,
) -> Result<Cow<'a, [u8]>, ImportError> {
    if uri.starts_with("data:") {
        return decode_data_uri(uri, ptr, budget).map(Cow::Owned);
    }
    // An absolute web address: the resolver has it (the browser fetched it) or says why not.
    if !is_web_uri(uri) {
        check_relative_uri(uri, ptr)?;
    }
    let bytes = resolver.resolve(uri).map_err(|e| ImportError::new(ptr, format!("cannot load '{uri}': {e}")))?;
    Ok(Cow::Owned(bytes))
}

/// Whether `buffer` is marked as the fallback of a meshopt compression extension (the
/// uncompressed data, for loaders without the extension).
fn is_fallback(buffer: &Obj, ptr: &str) -> Result<bool, ImportError> {
    for name in super::meshopt::EXTENSIONS {
        if let Some(x) = super::json::extension(buffer, name, ptr)?
            && super::json::opt_bool(x, "fallback", &format!("{ptr}/extensions/{name}"))?.unwrap_or(false)
        {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Loads every buffer, each cut to its declared `byteLength`. The declared lengths are
/// checked against the budget before anything is loaded. A buffer with no data (no `uri`, and
/// not the GLB's BIN chunk) is `None`: refused only where something reads it; so is a meshopt
/// fallback buffer, the uncompressed copy of views the importer decodes itself (not loaded).
pub(crate) fn load_buffers<'a>(
    root: &Obj,
    container: &Container<'a>,
    resolver: &dyn Resolver,
    budget: &mut Budget,
) -> Result<Vec<Option<Cow<'a, [u8]>>>, ImportError> {
    let buffers = objects(root, "buffers", "")?;
    // Per buffer: its declared length, and its URI when it is to be loaded from one.
    let mut sources = Vec::with_capacity(buffers.len());
    for (buffer, ptr) in &buffers {
        let len = req_u64(buffer, "byteLength", ptr)?;
        if len == 0 {
            return Err(ImportError::new(child(ptr, "byteLength"), "byteLength must be at least 1"));
        }
        let uri = match opt_str(buffer, "uri", ptr)? {
            Some(_) if is_fallback(buffer, ptr)? => None,
            uri => uri,
        };
        if uri.is_some() {
            budget.take(Some(len), ptr, &format!("buffer of byteLength {len}"))?;
        }
        sources.push((len, uri, buffer.contains_key("uri")));
    }
    let mut out = Vec::with_capacity(buffers.len());
    for (i, ((_, ptr), &(len, uri, has_uri))) in buffers.iter().zip(&sources).enumerate() {
        let uri_ptr = child(ptr, "uri");
        let bytes: Cow<'a, [u8]> = match uri {
            Some(uri) => load_uri(uri, &uri_ptr, resolver, budget)?,
            // A fallback buffer (it has a `uri`) is not the GLB's BIN chunk either.
            None if has_uri => {
                out.push(None);
                continue;
            }
            None => match container.bin {
                Some(bin) if i == 0 => Cow::Borrowed(bin),
                _ => {
                    out.push(None);
                    continue;
                }
            },
        };
        let got = bytes.len() as u64;
        if got < len {
            return Err(ImportError::new(ptr, format!("byteLength {len} exceeds the {got} bytes of its data")));
        }
        // `len <= got`, a usize, so the cast is lossless.
        out.push(Some(match bytes {
            Cow::Borrowed(b) => Cow::Borrowed(&b[..len as usize]),
            Cow::Owned(mut v) => {
                v.truncate(len as usize);
                Cow::Owned(v)
            }
        }));
    }
    Ok(out)
}

/// A GLB file of `json` (the JSON chunk, padded with spaces to 4 bytes) and an optional BIN
/// chunk (padded with zeros): the container the importer reads. `None` when the file would
/// exceed the format's 4 GiB. (Tests, benchmarks and fuzz targets build their documents with it.)
pub fn glb(json: &[u8], bin: Option<&[u8]>) -> Option<Vec<u8>> {
    let pad = |n: usize| n.next_multiple_of(4);
    let bin_length = bin.map_or(0, |b| 8 + pad(b.len()));
    let total = 20 + pad(json.len()) + bin_length;
    let total32 = u32::try_from(total).ok()?;
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(total32.to_le_bytes());
    out.extend((pad(json.len()) as u32).to_le_bytes());
    out.extend(CHUNK_JSON.to_le_bytes());
    out.extend(json);
    out.resize(20 + pad(json.len()), b' ');
    if let Some(bin) = bin {
        out.extend((pad(bin.len()) as u32).to_le_bytes());
        out.extend(CHUNK_BIN.to_le_bytes());
        out.extend(bin);
        out.resize(total, 0);
    }
    Some(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// [`super::glb`], which tests use with small documents only.
    pub(crate) fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
        super::glb(json, bin).expect("a GLB under 4 GiB")
    }

    fn split_err(bytes: &[u8]) -> String {
        split(bytes, &mut Vec::new()).expect_err("refused").message
    }

    #[test]
    fn glb_chunks_are_split() {
        let file = glb(b"{}", Some(&[1, 2, 3, 4]));
        let c = split(&file, &mut Vec::new()).expect("valid");
        assert_eq!(c.json, b"{}  ");
        assert_eq!(c.bin, Some(&[1u8, 2, 3, 4][..]));
    }

    #[test]
    fn broken_glb_headers_are_refused() {
        let file = glb(b"{}", Some(&[0; 8]));
        assert!(split_err(&file[..10]).contains("truncated header"));
        assert!(split_err(&file[..file.len() - 4]).contains("does not match the file size"));
        let mut v1 = file.clone();
        v1[4] = 1;
        assert!(split_err(&v1).contains("version 1"));
        // A BIN chunk claiming more bytes than remain (header length fixed up to match).
        let mut long = file.clone();
        let bin_len_at = 12 + 8 + 4;
        long[bin_len_at..bin_len_at + 4].copy_from_slice(&1000u32.to_le_bytes());
        assert!(split_err(&long).contains("declares 1000 bytes"));
        // A BIN chunk first.
        let mut swapped = file.clone();
        swapped[16..20].copy_from_slice(&CHUNK_BIN.to_le_bytes());
        assert!(split_err(&swapped).contains("first chunk must be JSON"));
        // Bytes after the last chunk, too few for a chunk header, counted in the header's length or
        // after it: ignored with a warning. Eight or more are a chunk header, and a truncated one is refused.
        let mut tail = file.clone();
        tail.extend([0, 0, 0, 0]);
        let len = tail.len() as u32;
        tail[8..12].copy_from_slice(&len.to_le_bytes());
        let mut warnings = Vec::new();
        assert_eq!(split(&tail, &mut warnings).expect("padding").bin, Some(&[0u8; 8][..]));
        assert_eq!(warnings[0].message, "4 bytes after the last GLB chunk are ignored");
        let mut appended = file.clone();
        appended.extend([7; 20]);
        let mut warnings = Vec::new();
        assert_eq!(split(&appended, &mut warnings).expect("appended").bin, Some(&[0u8; 8][..]));
        assert_eq!(warnings[0].message, "20 bytes after the GLB's declared length of 40 are ignored");
        let mut dangling = file;
        dangling.extend([9, 0, 0, 0, 0x42, 0x49, 0x4E, 0x00, 1]);
        let len = dangling.len() as u32;
        dangling[8..12].copy_from_slice(&len.to_le_bytes());
        assert!(split_err(&dangling).contains("declares 9 bytes, but only 1 remain"));
    }

    #[test]
    fn data_uris_are_checked() {
        let mut budget = Budget::new(1 << 20);
        let ok = decode_data_uri("data:application/octet-stream;base64,AQIDBA==", "/b", &mut budget);
        assert_eq!(ok.expect("valid"), vec![1, 2, 3, 4]);
        assert!(decode_data_uri("data:application/octet-stream;base64,AQID*A==", "/b", &mut budget).is_err());
        assert!(decode_data_uri("data:application/octet-stream;base64,AQIDB", "/b", &mut budget).is_err());
        // RFC 2397 without base64: the characters themselves, percent-encoded.
        let plain = decode_data_uri("data:application/octet-stream,%01%02%FFab%zz%4", "/b", &mut budget);
        assert_eq!(plain.expect("percent-encoded"), [1, 2, 255, b'a', b'b', b'%', b'z', b'z', b'%', b'4']);
        assert_eq!(decode_data_uri("data:,", "/b", &mut budget).expect("empty"), Vec::<u8>::new());
        assert!(decode_data_uri("data:application/octet-stream;base64", "/b", &mut budget).is_err());
        let mut tiny = Budget::new(2);
        let e = decode_data_uri("data:application/octet-stream;base64,AQIDBA==", "/b", &mut tiny).expect_err("budget");
        assert!(e.message.contains("import budget"), "{e}");
    }

    #[test]
    fn external_uris_stay_inside_the_folder() {
        for ok in ["a.bin", "sub/a%20b.bin", "./x/../a.bin"] {
            assert!(check_relative_uri(ok, "/u").is_ok(), "{ok}");
        }
        for bad in
            ["../../x", "/etc/passwd", "http://example.com/a.bin", "file:///a", "C:\\a.bin", "a/../../b", "%2E%2E/x"]
        {
            assert!(check_relative_uri(bad, "/u").is_err(), "{bad}");
        }
        assert_eq!(percent_decode("a%20b%2"), "a b%2");
    }
}
