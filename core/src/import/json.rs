//! Typed, pointer-carrying reads from the glTF JSON tree (`tree::Value`).
//!
//! Every reader takes the JSON pointer of the object it reads from; errors name the
//! pointer of the offending member.

use super::tree::Map;
pub(crate) use super::tree::Value;
use crate::error::ImportError;
use std::fmt::Display;

/// A JSON object.
pub(crate) type Obj<'j> = Map<'j>;

/// `"{ptr}/{key}"`.
pub(crate) fn child(ptr: &(impl Display + ?Sized), key: impl Display) -> String {
    format!("{ptr}/{key}")
}

/// An error at `{ptr}/{key}`.
pub(crate) fn member_error(ptr: &(impl Display + ?Sized), key: &str, message: impl Into<String>) -> ImportError {
    ImportError::new(child(ptr, key), message)
}

/// `v` as an object.
pub(crate) fn object<'a>(v: &'a Value<'a>, ptr: &(impl Display + ?Sized)) -> Result<&'a Obj<'a>, ImportError> {
    v.as_object().ok_or_else(|| ImportError::new(ptr.to_string(), "expected a JSON object"))
}

/// The array `obj[key]`; empty when absent.
pub(crate) fn array<'a>(
    obj: &'a Obj<'a>,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<&'a [Value<'a>], ImportError> {
    match obj.get(key) {
        None => Ok(&[]),
        Some(Value::Array(items)) => Ok(items),
        Some(_) => Err(member_error(ptr, key, "expected an array")),
    }
}

/// The objects of the array `obj[key]`, each with its pointer `"{ptr}/{key}/{i}"`.
pub(crate) fn objects<'a>(
    obj: &'a Obj<'a>,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Vec<(&'a Obj<'a>, String)>, ImportError> {
    Ok(items(obj, key, &ptr)?.into_iter().map(|(o, p)| (o, p.to_string())).collect())
}

/// The objects of the array `obj[key]`, each with its pointer written out only where a
/// message needs it (for the arrays with an element per accessor, view or channel).
pub(crate) fn items<'a, 'p>(
    obj: &'a Obj<'a>,
    key: &'p str,
    ptr: &'p dyn Display,
) -> Result<Vec<(&'a Obj<'a>, Ptr<'p>)>, ImportError> {
    array(obj, key, ptr)?
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let p = Ptr { parent: ptr, key, index: Some(i) };
            object(v, &p).map(|o| (o, p))
        })
        .collect()
}

/// A JSON pointer written out only when a message needs it: `{parent}/{key}/{index}` for an
/// element of an array, `{parent}/{key}` for a member.
#[derive(Clone, Copy)]
pub(crate) struct Ptr<'a> {
    parent: &'a dyn Display,
    key: &'a str,
    index: Option<usize>,
}

impl<'a> Ptr<'a> {
    /// `{parent}/{key}`.
    pub(crate) fn member(parent: &'a dyn Display, key: &'a str) -> Self {
        Ptr { parent, key, index: None }
    }

    /// `{parent}/{key}/{index}`.
    pub(crate) fn element(parent: &'a dyn Display, key: &'a str, index: usize) -> Self {
        Ptr { parent, key, index: Some(index) }
    }
}

impl Display for Ptr<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.index {
            Some(i) => write!(f, "{}/{}/{i}", self.parent, self.key),
            None => write!(f, "{}/{}", self.parent, self.key),
        }
    }
}

impl From<Ptr<'_>> for String {
    fn from(p: Ptr<'_>) -> String {
        p.to_string()
    }
}

/// The optional object `obj[key]`.
pub(crate) fn opt_object<'a>(
    obj: &'a Obj<'a>,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Option<&'a Obj<'a>>, ImportError> {
    // The pointer is written only for an error (these reads run for every element of a file).
    obj.get(key).map(|v| v.as_object().ok_or_else(|| member_error(ptr, key, "expected a JSON object"))).transpose()
}

/// The optional non-negative integer `obj[key]`; written as a float with no fraction (`1.0`)
/// it is read as that integer (JSON does not tell them apart).
pub(crate) fn opt_u64(obj: &Obj, key: &str, ptr: &(impl Display + ?Sized)) -> Result<Option<u64>, ImportError> {
    obj.get(key)
        .map(|v| as_u64(v).ok_or_else(|| member_error(ptr, key, format!("expected a non-negative integer, got {v}"))))
        .transpose()
}

/// `v` as a non-negative integer, also when written as a float with no fraction (`1.0`).
pub(crate) fn as_u64(v: &Value) -> Option<u64> {
    v.as_u64()
        .or_else(|| v.as_f64().filter(|x| x.fract() == 0.0 && (0.0..=MAX_EXACT_INTEGER).contains(x)).map(|x| x as u64))
}

/// The largest integer an `f64` holds exactly (2^53).
const MAX_EXACT_INTEGER: f64 = 9_007_199_254_740_992.0;

/// The required non-negative integer `obj[key]`.
pub(crate) fn req_u64(obj: &Obj, key: &str, ptr: &(impl Display + ?Sized)) -> Result<u64, ImportError> {
    opt_u64(obj, key, ptr)?.ok_or_else(|| member_error(ptr, key, "missing"))
}

/// The optional index `obj[key]` into an array of `len` `what`s, checked to be in range.
pub(crate) fn opt_index(
    obj: &Obj,
    key: &str,
    ptr: &(impl Display + ?Sized),
    len: usize,
    what: &str,
) -> Result<Option<u32>, ImportError> {
    match opt_u64(obj, key, ptr)? {
        None => Ok(None),
        Some(i) => match u32::try_from(i) {
            Ok(n) if u64::from(n) < len as u64 => Ok(Some(n)),
            _ => Err(out_of_range(i, len, what, &child(ptr, key))),
        },
    }
}

/// The required index `obj[key]` into an array of `len` `what`s.
pub(crate) fn req_index(
    obj: &Obj,
    key: &str,
    ptr: &(impl Display + ?Sized),
    len: usize,
    what: &str,
) -> Result<u32, ImportError> {
    opt_index(obj, key, ptr, len, what)?.ok_or_else(|| member_error(ptr, key, "missing"))
}

/// `i` as an index into `len` `what`s (error at `ptr` otherwise).
pub(crate) fn check_index(i: u64, len: usize, what: &str, ptr: &(impl Display + ?Sized)) -> Result<u32, ImportError> {
    match u32::try_from(i) {
        Ok(n) if u64::from(n) < len as u64 => Ok(n),
        _ => Err(out_of_range(i, len, what, ptr)),
    }
}

fn out_of_range(i: u64, len: usize, what: &str, ptr: &(impl Display + ?Sized)) -> ImportError {
    ImportError::new(ptr.to_string(), format!("{what} index {i} is out of range (the document has {len})"))
}

/// A finite JSON number as `f32` (errors at `ptr()`).
fn to_f32(v: &Value, ptr: impl FnOnce() -> String) -> Result<f32, ImportError> {
    match v.as_f64() {
        None => Err(ImportError::new(ptr(), format!("expected a number, got {v}"))),
        Some(x) if (x as f32).is_finite() => Ok(x as f32),
        Some(_) => Err(ImportError::new(ptr(), format!("number {v} does not fit a 32-bit float"))),
    }
}

/// The optional number `obj[key]`.
pub(crate) fn opt_f32(obj: &Obj, key: &str, ptr: &(impl Display + ?Sized)) -> Result<Option<f32>, ImportError> {
    obj.get(key).map(|v| to_f32(v, || child(ptr, key))).transpose()
}

/// The optional array of numbers `obj[key]`.
pub(crate) fn opt_f32_list(
    obj: &Obj,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Option<Vec<f32>>, ImportError> {
    let Some(v) = obj.get(key) else { return Ok(None) };
    let items = v.as_array().ok_or_else(|| member_error(ptr, key, "expected an array of numbers"))?;
    items.iter().enumerate().map(|(i, x)| to_f32(x, || format!("{ptr}/{key}/{i}"))).collect::<Result<_, _>>().map(Some)
}

/// The optional array of exactly `N` numbers `obj[key]`.
pub(crate) fn opt_f32_array<const N: usize>(
    obj: &Obj,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Option<[f32; N]>, ImportError> {
    let Some(list) = opt_f32_list(obj, key, ptr)? else { return Ok(None) };
    <[f32; N]>::try_from(list.as_slice())
        .map(Some)
        .map_err(|_| member_error(ptr, key, format!("expected {N} numbers, got {}", list.len())))
}

/// The optional string `obj[key]`.
pub(crate) fn opt_str<'a>(
    obj: &'a Obj<'_>,
    key: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Option<&'a str>, ImportError> {
    obj.get(key)
        .map(|v| v.as_str().ok_or_else(|| member_error(ptr, key, format!("expected a string, got {v}"))))
        .transpose()
}

/// The optional boolean `obj[key]`.
pub(crate) fn opt_bool(obj: &Obj, key: &str, ptr: &(impl Display + ?Sized)) -> Result<Option<bool>, ImportError> {
    obj.get(key)
        .map(|v| v.as_bool().ok_or_else(|| member_error(ptr, key, format!("expected true or false, got {v}"))))
        .transpose()
}

/// `name` of an element (a non-string name is ignored).
pub(crate) fn name(obj: &Obj) -> Option<String> {
    obj.get("name").and_then(Value::as_str).map(str::to_owned)
}

/// The optional extension object `obj.extensions[extension]`.
pub(crate) fn extension<'a>(
    obj: &'a Obj<'a>,
    extension: &str,
    ptr: &(impl Display + ?Sized),
) -> Result<Option<&'a Obj<'a>>, ImportError> {
    match opt_object(obj, "extensions", ptr)? {
        // The pointer is written out only for an error.
        Some(ext) => opt_object(ext, extension, &format_args!("{ptr}/extensions")),
        None => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readers_name_the_member() {
        let text = br#"{"a": -1, "b": [1, 2], "c": 1e300, "d": "x", "i": 5}"#;
        let arena = super::super::tree::Arena::new();
        let v = super::super::tree::parse(text, &arena).expect("JSON");
        let o = v.as_object().expect("object");
        assert_eq!(opt_u64(o, "a", "/x").expect_err("negative").pointer, "/x/a");
        assert_eq!(opt_f32(o, "c", "/x").expect_err("too large").pointer, "/x/c");
        assert_eq!(opt_f32_array::<3>(o, "b", "/x").expect_err("short").pointer, "/x/b");
        assert_eq!(opt_f32_array::<2>(o, "b", "/x").expect("two"), Some([1.0, 2.0]));
        assert_eq!(opt_str(o, "d", "/x").expect("str"), Some("x"));
        let e = opt_index(o, "i", "/x", 5, "node").expect_err("out of range");
        assert_eq!(e.to_string(), "/x/i: node index 5 is out of range (the document has 5)");
        assert_eq!(opt_index(o, "i", "/x", 6, "node").expect("in range"), Some(5));
        assert_eq!(array(o, "missing", "/x").expect("absent").len(), 0);
        assert!(objects(o, "b", "/x").is_err());
    }
}
