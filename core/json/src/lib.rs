//! The glTF JSON document as a tree that borrows its strings from the file's bytes.
//!
//! Its parser ([`parse`]) reads and refuses what serde_json does, with its messages' words and
//! positions, and is written for this tree alone. The tree replaces `serde_json::Value`, which
//! allocated a `String` for every key and string and a B-tree for every object: for a 2 MB JSON
//! chunk (KayKit's Knight, 8,839 accessors) that was most of the import's time. Objects are
//! sorted by key with duplicates resolved to the last (the reads and iteration order of
//! `serde_json::Map`), and looked up by binary search.
//!
//! The tree lives in an [`Arena`] the caller keeps beside the bytes: each array and object is
//! one exact-size slice in it and each escaped string a copy, so parsing makes no allocation of
//! its own per value and dropping the tree is freeing the arena's few blocks (a malloc and a
//! free for every array, object and key were a tenth of a small character's import in wasm;
//! BENCHMARKS.md, "Import and decoding", stop 61).
//!
//! A crate of its own so that the web bundle builds it at opt-level 3 (the importer at "s"): the
//! parse is a large part of a small character's import (BENCHMARKS.md, "Import and decoding",
//! stops 59 and 63).

mod parse;

pub use parse::Error;
use std::fmt;

/// Where a parsed tree's arrays, objects and escaped strings are kept: made by the caller,
/// outliving the tree ([`parse`]).
#[derive(Default)]
pub struct Arena(bumpalo::Bump);

impl Arena {
    /// An empty arena.
    pub fn new() -> Self {
        Self::default()
    }

    /// An arena with room for the tree of a document of `bytes` bytes before it grows.
    pub fn for_document(bytes: usize) -> Self {
        Self(bumpalo::Bump::with_capacity(bytes))
    }
}

/// A JSON value whose strings borrow from the parsed bytes where they have no escapes (from
/// the arena where they have).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value<'j> {
    Null,
    Bool(bool),
    Number(Number<'j>),
    String(&'j str),
    Array(&'j [Value<'j>]),
    Object(Map<'j>),
}

/// A JSON number as serde_json reads it: a non-negative integer, a negative one, or a float.
///
/// A float that is not one exact operation to read (a significand of 2^53 or more, as most
/// exporters' 17 digits are, or a power of ten beyond 10^22: most of them a file's bounds, which
/// the importer never reads) is kept as its text, checked to be within `f64`'s range, and read
/// when asked for ([`Value::as_f64`]). Either way the float is serde_json's reading: the one
/// operation where that is exact, serde_json's own reader on the text otherwise (core's correctly
/// rounded one, not otherwise in the web bundle, added 11 KB gzip to it, most of it its tables).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Number<'j> {
    U(u64),
    I(i64),
    F(f64),
    /// A float's text, as written in the document.
    Decimal(&'j str),
}

impl Number<'_> {
    /// The number as `f64` (exact for an integer up to 2^53), as serde_json reads it.
    pub fn as_f64(&self) -> f64 {
        match *self {
            Number::U(n) => n as f64,
            Number::I(n) => n as f64,
            Number::F(x) => x,
            // Checked to be a JSON number within range when parsed: this cannot fail.
            Number::Decimal(text) => read_decimal(text).unwrap_or(f64::NAN),
        }
    }
}

/// A JSON number's text as serde_json reads it (`None` beyond `f64`'s range).
pub(crate) fn read_decimal(text: &str) -> Option<f64> {
    text.parse::<serde_json::Number>().ok()?.as_f64()
}

/// A JSON object: its members sorted by key, each key once.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Map<'j>(&'j [(&'j str, Value<'j>)]);

/// Parses `bytes` as one JSON value, its arrays, objects and escaped strings kept in `arena`.
pub fn parse<'j>(bytes: &'j [u8], arena: &'j Arena) -> Result<Value<'j>, Error> {
    parse_counted(bytes, arena).map(|(value, _)| value)
}

/// Parses `bytes` as one JSON value (as [`parse`]); also returns how many values were parsed
/// (the root and every item and member, a repeated key's dropped values included: they were
/// held while parsing).
pub fn parse_counted<'j>(bytes: &'j [u8], arena: &'j Arena) -> Result<(Value<'j>, u64), Error> {
    parse::parse(bytes, &arena.0)
}

impl<'j> Value<'j> {
    /// The object, if this is one.
    pub fn as_object(&self) -> Option<&Map<'j>> {
        match self {
            Value::Object(m) => Some(m),
            _ => None,
        }
    }

    /// The items, if this is an array.
    pub fn as_array(&self) -> Option<&[Value<'j>]> {
        match self {
            Value::Array(items) => Some(items),
            _ => None,
        }
    }

    /// The string, if this is one.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::String(s) => Some(s),
            _ => None,
        }
    }

    /// The boolean, if this is one.
    pub fn as_bool(&self) -> Option<bool> {
        match *self {
            Value::Bool(b) => Some(b),
            _ => None,
        }
    }

    /// The number, if it is an integer from 0 to `u64::MAX` written without a fraction or
    /// exponent (as `serde_json::Value::as_u64`).
    pub fn as_u64(&self) -> Option<u64> {
        match *self {
            Value::Number(Number::U(n)) => Some(n),
            _ => None,
        }
    }

    /// Any number as `f64`.
    pub fn as_f64(&self) -> Option<f64> {
        match *self {
            Value::Number(n) => Some(n.as_f64()),
            _ => None,
        }
    }
}

impl<'j> Map<'j> {
    /// The member `key`.
    pub fn get(&self, key: &str) -> Option<&'j Value<'j>> {
        let members = self.0;
        if members.len() <= 12 {
            // glTF's objects are small: comparing lengths first beats a binary search's memcmps.
            return members.iter().find(|(k, _)| same_key(k.as_bytes(), key.as_bytes())).map(|(_, v)| v);
        }
        members.binary_search_by(|(k, _)| (*k).cmp(key)).ok().map(|i| &members[i].1)
    }

    /// Whether the object has a member `key`.
    pub fn contains_key(&self, key: &str) -> bool {
        self.get(key).is_some()
    }

    /// The members in key order.
    pub fn iter(&self) -> impl Iterator<Item = (&'j str, &'j Value<'j>)> {
        self.0.iter().map(|(k, v)| (*k, v))
    }

    /// The members as written (`keys` and `values` in pairs), sorted by key, a repeated key's
    /// last value kept, in `arena`.
    fn from_members(keys: &[&'j str], values: &[Value<'j>], arena: &'j bumpalo::Bump) -> Self {
        let members = arena.alloc_slice_fill_iter(keys.iter().copied().zip(values.iter().copied()));
        let mut kept = members.len();
        if members.windows(2).any(|w| w[0].0 >= w[1].0) {
            // Stable: of equal keys the last written stays last, and is the one kept.
            members.sort_by(|a, b| a.0.cmp(b.0));
            kept = 0;
            for i in 0..members.len() {
                if members.get(i + 1).is_some_and(|next| next.0 == members[i].0) {
                    continue;
                }
                members.swap(kept, i);
                kept += 1;
            }
        }
        let members: &'j [(&'j str, Value<'j>)] = members;
        Map(members.get(..kept).unwrap_or_default())
    }
}

/// Whether two keys are the same: for the lengths of glTF's keys, as two eight-byte words or
/// byte by byte rather than a memcmp (a call in wasm, made for every member of the key's length
/// a lookup passes: most of an accessor's and a buffer view's are ten bytes long).
fn same_key(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let word =
        |s: &[u8], at: usize| s.get(at..at + 8).and_then(|w| <[u8; 8]>::try_from(w).ok()).map(u64::from_le_bytes);
    match a.len() {
        0..8 => a.iter().zip(b).all(|(x, y)| x == y),
        // The first eight bytes and the last eight (overlapping where shorter than 16).
        n @ 8..=16 => word(a, 0) == word(b, 0) && word(a, n - 8) == word(b, n - 8),
        _ => a == b,
    }
}

impl<'j> IntoIterator for &Map<'j> {
    type Item = (&'j str, &'j Value<'j>);
    type IntoIter = std::iter::Map<
        std::slice::Iter<'j, (&'j str, Value<'j>)>,
        fn(&'j (&'j str, Value<'j>)) -> (&'j str, &'j Value<'j>),
    >;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter().map(|(k, v)| (*k, v))
    }
}

/// Compact JSON, as `serde_json::Value` writes itself (used in messages: "got {v}").
impl fmt::Display for Value<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Null => f.write_str("null"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Number(Number::U(n)) => write!(f, "{n}"),
            Value::Number(Number::I(n)) => write!(f, "{n}"),
            Value::Number(n) => write!(f, "{:?}", n.as_f64()),
            Value::String(s) => write_string(f, s),
            Value::Array(items) => {
                f.write_str("[")?;
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    write!(f, "{item}")?;
                }
                f.write_str("]")
            }
            Value::Object(map) => {
                f.write_str("{")?;
                for (i, (k, v)) in map.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    write_string(f, k)?;
                    write!(f, ":{v}")?;
                }
                f.write_str("}")
            }
        }
    }
}

/// `s` as a JSON string literal.
fn write_string(f: &mut fmt::Formatter<'_>, s: &str) -> fmt::Result {
    f.write_str("\"")?;
    for c in s.chars() {
        match c {
            '"' => f.write_str("\\\"")?,
            '\\' => f.write_str("\\\\")?,
            '\n' => f.write_str("\\n")?,
            '\r' => f.write_str("\\r")?,
            '\t' => f.write_str("\\t")?,
            c if u32::from(c) < 0x20 => write!(f, "\\u{:04x}", u32::from(c))?,
            c => write!(f, "{c}")?,
        }
    }
    f.write_str("\"")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_like_serde_json() {
        let text = br#"{"b": [1, -2, 1.5, "x\"y", null, true], "a": {"k": 1, "k": 2}, "c": "plain"}"#;
        let arena = Arena::new();
        let v = parse(text, &arena).expect("parses");
        let expected: serde_json::Value = serde_json::from_slice(text).expect("parses");
        assert_eq!(v.to_string(), expected.to_string());
        let o = v.as_object().expect("object");
        assert_eq!(o.iter().map(|(k, _)| k).collect::<Vec<_>>(), ["a", "b", "c"]);
        assert_eq!(o.get("a").and_then(Value::as_object).and_then(|a| a.get("k")).and_then(Value::as_u64), Some(2));
        let inside = text.as_ptr_range();
        assert!(
            matches!(o.get("c"), Some(Value::String(s)) if *s == "plain" && inside.contains(&s.as_ptr())),
            "not borrowed"
        );
        let b = o.get("b").and_then(Value::as_array).expect("array");
        assert_eq!((b[0].as_u64(), b[1].as_u64(), b[1].as_f64(), b[2].as_u64()), (Some(1), None, Some(-2.0), None));
        assert_eq!(b[3].as_str(), Some("x\"y"));
        assert!(parse(b"{\"a\": 1e400}", &arena).is_err());
        let deep = format!("{}{}", "[".repeat(200), "]".repeat(200));
        assert!(parse(deep.as_bytes(), &arena).is_err(), "serde_json's recursion limit");
        assert!(parse(b"{\"a\": 1,}", &arena).expect_err("trailing comma").to_string().contains("line 1"));
    }

    #[test]
    fn keys_compare_as_bytes_do() {
        for len in 0..24 {
            let a: Vec<u8> = (0..len).map(|i| b'a' + (i % 26) as u8).collect();
            assert!(same_key(&a, &a.clone()), "{len}");
            for at in 0..len {
                let mut b = a.clone();
                b[at] ^= 0x20;
                assert!(!same_key(&a, &b), "{len}: byte {at}");
            }
            assert!(!same_key(&a, &a[..len.saturating_sub(1)]) || len == 0, "{len}: shorter");
        }
    }

    #[test]
    fn counts_every_value() {
        // The root, "a" and its two items, "b", "c" and its item: 7 values.
        let arena = Arena::new();
        let (_, values) = parse_counted(br#"{"a": [1, "x"], "b": {}, "c": {"d": null}}"#, &arena).expect("parses");
        assert_eq!(values, 7);
        assert_eq!(parse_counted(b"3", &arena).expect("parses").1, 1);
        assert_eq!(parse_counted(b"[[], [[]]]", &arena).expect("parses").1, 4);
        assert_eq!(parse_counted(br#"{"a": 1, "a": [2]}"#, &arena).expect("parses").1, 4);
    }
}
