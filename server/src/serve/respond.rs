//! HTTP semantics of serving one file ([`plan`]): content negotiation between the file and
//! its precompressed siblings, strong ETags and `If-None-Match` (304), single byte ranges
//! (206/416, `If-Range`), `Cache-Control`, and HEAD. Pure: no I/O, so every rule is unit-tested.

use super::files::{Content, Found, Variant};
use super::mime;
use hyper::header::{
    ACCEPT_ENCODING, ACCEPT_RANGES, CACHE_CONTROL, CONTENT_ENCODING, CONTENT_LENGTH, CONTENT_RANGE, CONTENT_TYPE, ETAG,
    HeaderMap, HeaderValue, IF_NONE_MATCH, IF_RANGE, RANGE, VARY,
};
use hyper::{Method, StatusCode};
use std::ops::Range;
use std::path::Path;

/// `Cache-Control` of files whose name carries a content hash ([`is_content_hashed`]).
pub const CACHE_IMMUTABLE: &str = "public, max-age=31536000, immutable";
/// `Cache-Control` of every other file: caches keep it but revalidate (cheap: ETag → 304).
pub const CACHE_REVALIDATE: &str = "no-cache";

/// What to answer for a file: status, headers, and which bytes (if any) form the body.
#[derive(Debug)]
pub struct Plan {
    /// 200, 206, 304 or 416.
    pub status: StatusCode,
    /// Every header of the response.
    pub headers: HeaderMap,
    /// The bytes to send (a representation and a byte range of it); `None` for HEAD, 304, 416.
    pub body: Option<(Content, Range<u64>)>,
}

/// Plans the response to a GET or HEAD of `found`, given the request headers.
pub fn plan(method: &Method, request: &HeaderMap, found: &Found) -> Plan {
    let (variant, encoding) = negotiate(request, found);
    let mut headers = HeaderMap::new();
    insert(&mut headers, ETAG, &variant.etag);
    headers.insert(CACHE_CONTROL, HeaderValue::from_static(cache_control(&found.path)));
    if found.gzip.is_some() || found.br.is_some() {
        headers.insert(VARY, HeaderValue::from_static("Accept-Encoding"));
    }
    if none_match(request, &variant.etag) {
        return Plan { status: StatusCode::NOT_MODIFIED, headers, body: None };
    }
    headers.insert(ACCEPT_RANGES, HeaderValue::from_static("bytes"));
    let len = variant.len;
    let (status, range) = match byte_range(request, &variant.etag, len) {
        Ranged::Full => (StatusCode::OK, 0..len),
        Ranged::Part(r) => {
            let content_range = format!("bytes {}-{}/{len}", r.start, r.end - 1);
            insert(&mut headers, CONTENT_RANGE, &content_range);
            (StatusCode::PARTIAL_CONTENT, r)
        }
        Ranged::Unsatisfiable => {
            insert(&mut headers, CONTENT_RANGE, &format!("bytes */{len}"));
            headers.insert(CONTENT_LENGTH, HeaderValue::from(0u64));
            return Plan { status: StatusCode::RANGE_NOT_SATISFIABLE, headers, body: None };
        }
    };
    headers.insert(CONTENT_TYPE, HeaderValue::from_static(mime::content_type(Path::new(&found.path))));
    if let Some(encoding) = encoding {
        headers.insert(CONTENT_ENCODING, HeaderValue::from_static(encoding));
    }
    headers.insert(CONTENT_LENGTH, HeaderValue::from(range.end - range.start));
    let body = (method != Method::HEAD && !range.is_empty()).then(|| (variant.content.clone(), range));
    Plan { status, headers, body }
}

fn insert(headers: &mut HeaderMap, name: hyper::header::HeaderName, value: &str) {
    // Values built here are ASCII (hex ETags, digits); a failure would only drop the header.
    if let Ok(v) = HeaderValue::from_str(value) {
        headers.insert(name, v);
    }
}

/// The representation to send: brotli, else gzip, when the client accepts it and the file has
/// that sibling; else the file itself. Returns the `Content-Encoding` with it.
fn negotiate<'a>(request: &HeaderMap, found: &'a Found) -> (&'a Variant, Option<&'static str>) {
    let accept = request.get_all(ACCEPT_ENCODING).iter().filter_map(|v| v.to_str().ok()).collect::<Vec<_>>().join(",");
    if let Some(br) = found.br.as_ref().filter(|_| accepts(&accept, "br")) {
        return (br, Some("br"));
    }
    if let Some(gz) = found.gzip.as_ref().filter(|_| accepts(&accept, "gzip")) {
        return (gz, Some("gzip"));
    }
    (&found.identity, None)
}

/// Whether `Accept-Encoding` value `accept` allows `coding` (named or `*`, with q > 0).
pub fn accepts(accept: &str, coding: &str) -> bool {
    let mut star = None;
    for item in accept.split(',') {
        let mut parts = item.split(';');
        let token = parts.next().unwrap_or_default().trim();
        let q = parts
            .find_map(|p| {
                let p = p.trim();
                p.strip_prefix("q=").or_else(|| p.strip_prefix("Q="))
            })
            .map_or(1.0, |v| v.trim().parse::<f32>().unwrap_or(0.0));
        if token.eq_ignore_ascii_case(coding) {
            return q > 0.0;
        }
        if token == "*" {
            star = Some(q > 0.0);
        }
    }
    star.unwrap_or(false)
}

/// `If-None-Match` matches `etag` (weak comparison, as RFC 9110 asks for this header).
fn none_match(request: &HeaderMap, etag: &str) -> bool {
    request
        .get_all(IF_NONE_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(str::trim)
        .any(|tag| tag == "*" || tag.strip_prefix("W/").unwrap_or(tag) == etag)
}

/// `Cache-Control` for the file at relative path `path`.
pub fn cache_control(path: &str) -> &'static str {
    if is_content_hashed(path) { CACHE_IMMUTABLE } else { CACHE_REVALIDATE }
}

/// Whether a file name carries a content hash, by the bundlers' `name.HASH.ext` convention:
/// a dot-separated part between the first and the last that is 16 to 64 lowercase hex digits
/// (`kloub_web.3f2a9c0d1e4b5a6f.js`). Such a file never changes, so it may be cached for a year.
pub fn is_content_hashed(path: &str) -> bool {
    let name = path.rsplit('/').next().unwrap_or(path);
    let parts: Vec<&str> = name.split('.').collect();
    parts.len() >= 3
        && parts[1..parts.len() - 1].iter().any(|p| {
            (16..=64).contains(&p.len()) && p.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
        })
}

/// What a `Range` header asks of a representation of `len` bytes.
#[derive(Debug, PartialEq, Eq)]
enum Ranged {
    /// No (usable) range: the whole representation.
    Full,
    /// One satisfiable range, end exclusive.
    Part(Range<u64>),
    /// The range starts past the end: 416.
    Unsatisfiable,
}

/// Reads a single `bytes=` range. Several ranges, other units, bad syntax, and an `If-Range`
/// that does not match `etag` (strongly) all give the whole representation, as RFC 9110 allows.
fn byte_range(request: &HeaderMap, etag: &str, len: u64) -> Ranged {
    let Some(spec) = request.get(RANGE).and_then(|v| v.to_str().ok()) else {
        return Ranged::Full;
    };
    if let Some(if_range) = request.get(IF_RANGE)
        && if_range.to_str().ok().map(str::trim) != Some(etag)
    {
        return Ranged::Full;
    }
    let spec = spec.trim();
    let Some(set) = spec.get(..6).filter(|unit| unit.eq_ignore_ascii_case("bytes=")).and_then(|_| spec.get(6..)) else {
        return Ranged::Full;
    };
    if set.contains(',') {
        return Ranged::Full;
    }
    let Some((first, last)) = set.split_once('-') else {
        return Ranged::Full;
    };
    let number = |s: &str| {
        let s = s.trim();
        (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())).then(|| s.parse::<u64>().ok()).flatten()
    };
    match (first.trim().is_empty(), number(first), number(last)) {
        // `-N`: the last N bytes.
        (true, _, Some(n)) => {
            if n == 0 || len == 0 {
                Ranged::Unsatisfiable
            } else {
                Ranged::Part(len - n.min(len)..len)
            }
        }
        // `A-` or `A-B`.
        (false, Some(start), end) => {
            let end = match end {
                Some(e) if e < start => return Ranged::Full,
                Some(e) => e,
                None if last.trim().is_empty() => u64::MAX,
                None => return Ranged::Full,
            };
            if start >= len { Ranged::Unsatisfiable } else { Ranged::Part(start..end.min(len - 1) + 1) }
        }
        _ => Ranged::Full,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bytes::Bytes;

    fn headers(pairs: &[(&str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (n, v) in pairs {
            h.append(
                hyper::header::HeaderName::from_bytes(n.as_bytes()).expect("name"),
                HeaderValue::from_str(v).expect("value"),
            );
        }
        h
    }

    fn variant(tag: &str, bytes: &'static [u8]) -> Variant {
        Variant {
            etag: format!("\"{tag}\""),
            len: bytes.len() as u64,
            content: Content::Memory(Bytes::from_static(bytes)),
        }
    }

    fn found(with_siblings: bool) -> Found {
        Found {
            path: "kloub_web.js".into(),
            identity: variant("id", b"0123456789"),
            gzip: with_siblings.then(|| variant("gz", b"gzip")),
            br: with_siblings.then(|| variant("br", b"br")),
        }
    }

    fn range(spec: &str, len: u64) -> Ranged {
        byte_range(&headers(&[("range", spec)]), "\"e\"", len)
    }

    #[test]
    fn ranges() {
        assert_eq!(range("bytes=0-3", 10), Ranged::Part(0..4));
        assert_eq!(range("bytes=5-", 10), Ranged::Part(5..10));
        assert_eq!(range("bytes=5-100", 10), Ranged::Part(5..10));
        assert_eq!(range("bytes=-3", 10), Ranged::Part(7..10));
        assert_eq!(range("bytes=-30", 10), Ranged::Part(0..10));
        assert_eq!(range("BYTES=9-9", 10), Ranged::Part(9..10));
        assert_eq!(range("bytes=10-", 10), Ranged::Unsatisfiable);
        assert_eq!(range("bytes=-0", 10), Ranged::Unsatisfiable);
        assert_eq!(range("bytes=0-", 0), Ranged::Unsatisfiable);
        for ignored in
            ["bytes=3-1", "bytes=0-1,3-4", "items=0-1", "bytes=x-1", "bytes=+1-2", "bytes=", "bytes=-", "bytes=1"]
        {
            assert_eq!(range(ignored, 10), Ranged::Full, "{ignored}");
        }
        let h = headers(&[("range", "bytes=0-1"), ("if-range", "\"e\"")]);
        assert_eq!(byte_range(&h, "\"e\"", 10), Ranged::Part(0..2));
        let h = headers(&[("range", "bytes=0-1"), ("if-range", "\"old\"")]);
        assert_eq!(byte_range(&h, "\"e\"", 10), Ranged::Full);
        let h = headers(&[("range", "bytes=0-1"), ("if-range", "W/\"e\"")]);
        assert_eq!(byte_range(&h, "\"e\"", 10), Ranged::Full, "strong comparison");
    }

    #[test]
    fn accept_encoding() {
        assert!(accepts("gzip, deflate, br", "br"));
        assert!(accepts("gzip;q=0.5", "gzip"));
        assert!(!accepts("gzip;q=0", "gzip"));
        assert!(!accepts("br;q=0, *", "br"));
        assert!(accepts("*", "br"));
        assert!(!accepts("*;q=0", "gzip"));
        assert!(!accepts("identity", "gzip"));
        assert!(!accepts("", "gzip"));
        assert!(accepts("GZIP", "gzip"));
    }

    #[test]
    fn negotiation_prefers_brotli_then_gzip() {
        let f = found(true);
        let get = |accept: &str| plan(&Method::GET, &headers(&[("accept-encoding", accept)]), &f);
        let p = get("gzip, br");
        assert_eq!(p.headers[CONTENT_ENCODING], "br");
        assert_eq!(p.headers[ETAG], "\"br\"");
        assert_eq!(p.headers[CONTENT_LENGTH], "2");
        assert_eq!(p.headers[VARY], "Accept-Encoding");
        assert_eq!(p.headers[CONTENT_TYPE], "text/javascript");
        let p = get("gzip");
        assert_eq!(p.headers[CONTENT_ENCODING], "gzip");
        assert_eq!(p.headers[ETAG], "\"gz\"");
        let p = get("identity");
        assert!(!p.headers.contains_key(CONTENT_ENCODING));
        assert_eq!(p.headers[ETAG], "\"id\"");
        assert_eq!(p.headers[VARY], "Accept-Encoding");
        let plain = plan(&Method::GET, &headers(&[("accept-encoding", "br")]), &found(false));
        assert!(!plain.headers.contains_key(CONTENT_ENCODING));
        assert!(!plain.headers.contains_key(VARY), "one representation only");
    }

    #[test]
    fn conditional_head_and_range_plans() {
        let f = found(false);
        let p = plan(&Method::GET, &headers(&[("if-none-match", "\"x\", W/\"id\"")]), &f);
        assert_eq!(p.status, StatusCode::NOT_MODIFIED);
        assert!(p.body.is_none());
        assert_eq!(p.headers[ETAG], "\"id\"");
        let p = plan(&Method::GET, &headers(&[("if-none-match", "\"x\"")]), &f);
        assert_eq!(p.status, StatusCode::OK);
        assert_eq!(p.body.as_ref().map(|(_, r)| r.clone()), Some(0..10));
        let p = plan(&Method::HEAD, &HeaderMap::new(), &f);
        assert_eq!((p.status, p.body.is_none()), (StatusCode::OK, true));
        assert_eq!(p.headers[CONTENT_LENGTH], "10");
        let p = plan(&Method::GET, &headers(&[("range", "bytes=2-4")]), &f);
        assert_eq!(p.status, StatusCode::PARTIAL_CONTENT);
        assert_eq!(p.headers[CONTENT_RANGE], "bytes 2-4/10");
        assert_eq!(p.headers[CONTENT_LENGTH], "3");
        assert_eq!(p.body.map(|(_, r)| r), Some(2..5));
        let p = plan(&Method::GET, &headers(&[("range", "bytes=10-")]), &f);
        assert_eq!(p.status, StatusCode::RANGE_NOT_SATISFIABLE);
        assert_eq!(p.headers[CONTENT_RANGE], "bytes */10");
    }

    #[test]
    fn hashed_names_are_immutable() {
        assert!(is_content_hashed("kloub_web.3f2a9c0d1e4b5a6f.js"));
        assert!(is_content_hashed("a/b.0123456789abcdef0123.wasm"));
        assert!(!is_content_hashed("kloub_web_bg.wasm"));
        assert!(!is_content_hashed("model.20240101.glb"), "too short to be a hash");
        assert!(!is_content_hashed("3f2a9c0d1e4b5a6f3f2a.js"), "the stem is not the hash");
        assert!(!is_content_hashed("a.3F2A9C0D1E4B5A6F.js"), "lowercase only");
        assert_eq!(cache_control("index.html"), CACHE_REVALIDATE);
        assert_eq!(cache_control("x.0123456789abcdef.css"), CACHE_IMMUTABLE);
    }
}
