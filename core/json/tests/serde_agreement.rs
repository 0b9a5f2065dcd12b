//! The parser against serde_json: the same documents read, the same refused, the same values
//! and the same positions in the messages.

use kloub_json::{Arena, Number, Value, parse};
use std::path::Path;

/// `a` and `b` as the same value: numbers of the same kind and value (a float bit for bit),
/// members in the same order.
fn same(a: &Value, b: &serde_json::Value, at: &str) {
    match (a, b) {
        (Value::Null, serde_json::Value::Null) => {}
        (Value::Bool(x), serde_json::Value::Bool(y)) => assert_eq!(x, y, "{at}"),
        (Value::Number(n), serde_json::Value::Number(m)) => match *n {
            Number::U(x) => assert_eq!(Some(x), m.as_u64(), "{at}"),
            Number::I(x) => assert_eq!((Some(x), m.is_u64()), (m.as_i64(), false), "{at}"),
            Number::F(_) | Number::Decimal(_) => {
                let x = n.as_f64();
                assert!(m.is_f64(), "{at}: {x} read as a float, serde_json reads {m}");
                let y = m.as_f64().expect("float");
                assert_eq!(x.to_bits(), y.to_bits(), "{at}: {x} against {y}");
            }
        },
        (Value::String(x), serde_json::Value::String(y)) => assert_eq!(x, y, "{at}"),
        (Value::Array(x), serde_json::Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (i, (x, y)) in x.iter().zip(y).enumerate() {
                same(x, y, &format!("{at}/{i}"));
            }
        }
        (Value::Object(x), serde_json::Value::Object(y)) => {
            let keys: Vec<_> = x.iter().map(|(k, _)| k).collect();
            assert_eq!(keys, y.keys().map(String::as_str).collect::<Vec<_>>(), "{at}");
            for ((k, x), y) in x.iter().zip(y.values()) {
                same(x, y, &format!("{at}/{k}"));
            }
        }
        _ => panic!("{at}: {a} against {b}"),
    }
}

/// Both read `text` alike, or both refuse it on the same line and column.
fn agree(text: &[u8]) -> bool {
    let arena = Arena::new();
    let ours = parse(text, &arena);
    let theirs = serde_json::from_slice::<serde_json::Value>(text);
    let shown = String::from_utf8_lossy(text);
    match (ours, theirs) {
        (Ok(a), Ok(b)) => {
            same(&a, &b, &shown);
            true
        }
        (Err(a), Err(b)) => {
            assert_eq!((a.line(), a.column()), (b.line(), b.column()), "{shown:?}: {a} against {b}");
            false
        }
        (a, b) => panic!("{shown:?}: {a:?} against {b:?}"),
    }
}

#[test]
fn reads_and_refuses_what_serde_json_does() {
    let deep = |n: usize| format!("{}{}", "[".repeat(n), "]".repeat(n));
    let read = [
        "0",
        "-0",
        "1",
        "-1",
        "18446744073709551615",
        "-9223372036854775808",
        "18446744073709551616",
        "-9223372036854775809",
        "123456789012345678901234567890",
        "0.1",
        "-0.0",
        "1e22",
        "1e23",
        "1E+2",
        "1e-2",
        "9007199254740993",
        "0.30000000000000004",
        "1.7976931348623157e308",
        "4.9e-324",
        "2.2250738585072014e-308",
        "1e-400",
        "0e99999999999999999999",
        "17976931348623157e292",
        "0.00001e313",
        "-1.7976931348623157e308",
        "0.000e400",
        "0.000000000000000000000000000001",
        "123.456e-7",
        "-1.5e3",
        "\"\"",
        "\"plain\"",
        "\"tab\\tand\\nnew\\\\\\\"/\\/\\b\\f\\r\"",
        "\"\\u00e9\\u20ac\"",
        "\"\\ud83d\\ude00\"",
        "\"é € 😀\"",
        "\"\\u0000\"",
        "true",
        "false",
        "null",
        " \t\r\n[ 1 , 2 ]\n ",
        "[]",
        "{}",
        "[[], {}]",
        "{\"a\": 1, \"a\": 2, \"b\": [true]}",
        "{\"k\\u0065y\": \"v\", \"key\": 3}",
        "{\"é\": 1, \"e\": 2, \"\": 3}",
    ];
    for text in read {
        assert!(agree(text.as_bytes()), "{text} is read");
    }
    assert!(agree(deep(127).as_bytes()), "127 deep is read");
    let refused = [
        "",
        " ",
        "01",
        "-",
        "--1",
        "+1",
        "1.",
        ".5",
        "1e",
        "1e+",
        "1.e3",
        "1e400",
        "-1e400",
        "1.8e308",
        "-1.8e308",
        "1e309",
        "0.1e310",
        "99999999999999999999e289",
        "0.00002e313",
        "0x10",
        "NaN",
        "Infinity",
        "tru",
        "nul",
        "nulll",
        "[1,]",
        "{\"a\":1,}",
        "[1 2]",
        "{\"a\" 1}",
        "{a: 1}",
        "{\"a\":}",
        "[",
        "{",
        "[1",
        "{\"a\":1",
        "\"open",
        "\"\\x\"",
        "\"\\u12\"",
        "\"\\u12g4\"",
        "\"\\ud83d\"",
        "\"\\ud83dx\"",
        "\"\\ud83d\\u0041\"",
        "\"\\ude00\"",
        "\"\\ud83d\\n\"",
        "\"\\ud83d\\",
        "\"\\u12",
        "\"raw\ttab\"",
        "\"raw\nline\"",
        "1 2",
        "[] []",
        "{}}",
        "\u{feff}{}",
        "[1,\n2,\n\n  ,3]",
        "\u{c}1",
    ];
    for text in refused {
        assert!(!agree(text.as_bytes()), "{text:?} is refused");
    }
    assert!(!agree(deep(128).as_bytes()), "128 deep is refused");
    assert!(!agree(b"\"\xff\""), "invalid UTF-8 in a string");
    assert!(!agree(b"[1, \"ok\", \"\xc3\"]"), "a cut character");
    assert!(!agree(b"\xef\xbb"), "invalid UTF-8 outside a string");
}

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

#[test]
fn agrees_with_serde_json_on_mutated_documents() {
    let seeds: [&[u8]; 3] = [
        br#"{"asset": {"version": "2.0"}, "nodes": [{"name": "b\u00e9\"x", "translation": [0.5, -1e-3, 12]}],
            "accessors": [{"count": 18446744073709551615, "min": [-0.0, 1.5E+2], "max": [-9223372036854775808]}],
            "extras": {"a": null, "b": true, "c": false, "d": "\ud83d\ude00 \\ \/ \b\f\n\r\t"}}"#,
        "[\"é€😀\", {\"\": []}, [[[1]]], 3.25e-7, -0, 0.1]".as_bytes(),
        include_bytes!("../../../tests/assets/khronos/AnimatedTriangle/glTF/AnimatedTriangle.gltf"),
    ];
    // Bytes that make or break JSON's grammar, and some that are not text.
    let alphabet = b"{}[]\",:\\/ \t\n0123456789.eE+-ubnrtfalsx\x01\x7f\xc3\xa9\xff";
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut read, mut refused) = (0, 0);
    for round in 0..30_000 {
        let mut text = seeds[round % seeds.len()].to_vec();
        for _ in 0..1 + rng.below(3) {
            let at = rng.below(text.len() + 1);
            let byte = alphabet[rng.below(alphabet.len())];
            match rng.below(3) {
                0 if at < text.len() => {
                    text.remove(at);
                }
                1 if at < text.len() => text[at] = byte,
                _ => text.insert(at, byte),
            }
        }
        if agree(&text) {
            read += 1;
        } else {
            refused += 1;
        }
    }
    // Both kinds are common enough that the comparison means something on each side.
    assert!(read > 3_000 && refused > 3_000, "{read} read, {refused} refused");
}

/// The JSON of every glTF and GLB among the test assets.
fn asset_documents(dir: &Path, found: &mut Vec<(String, Vec<u8>)>) {
    for entry in std::fs::read_dir(dir).expect("assets").flatten() {
        let path = entry.path();
        if path.is_dir() {
            asset_documents(&path, found);
            continue;
        }
        let bytes = std::fs::read(&path).expect("asset");
        let json = match path.extension().and_then(|e| e.to_str()) {
            Some("gltf") => bytes,
            Some("glb") => {
                let length = u32::from_le_bytes(bytes[12..16].try_into().expect("chunk length")) as usize;
                bytes[20..20 + length].to_vec()
            }
            _ => continue,
        };
        found.push((path.display().to_string(), json));
    }
}

#[test]
fn reads_every_asset_as_serde_json_does() {
    let mut documents = Vec::new();
    asset_documents(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/assets"), &mut documents);
    assert!(documents.len() >= 30, "{} documents", documents.len());
    for (path, json) in documents {
        let arena = Arena::new();
        let ours = parse(&json, &arena).unwrap_or_else(|e| panic!("{path}: {e}"));
        let theirs: serde_json::Value = serde_json::from_slice(&json).unwrap_or_else(|e| panic!("{path}: {e}"));
        same(&ours, &theirs, &path);
    }
}

#[test]
fn floats_are_read_as_serde_json_reads_them() {
    // Written as files have them (up to 17 significant digits, exponents near 0) and beyond:
    // each is read as serde_json reads it, bit for bit (one division where that is exact, which
    // serde_json does too; its reader on the text otherwise).
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let arena = Arena::new();
    let mut fast = 0;
    for round in 0..200_000 {
        let digits = 1 + rng.below(if round % 4 == 0 { 30 } else { 17 });
        let mut text: String = (0..digits).map(|_| char::from(b'0' + rng.below(10) as u8)).collect();
        let integer = 1 + rng.below(digits);
        if integer < digits || rng.below(2) == 0 {
            text.insert(integer.min(digits), '.');
            if text.ends_with('.') {
                text.push('5');
            }
        }
        let text = text.trim_start_matches('0');
        let mut text = if text.starts_with('.') || text.is_empty() { format!("0{text}") } else { text.to_string() };
        if rng.below(3) == 0 {
            text.push_str(&format!("e{}", rng.below(80) as i64 - 40));
        }
        if rng.below(2) == 0 {
            text.insert(0, '-');
        }
        let expected: f64 = serde_json::from_str(&text).expect("a float");
        let read = parse(text.as_bytes(), &arena).unwrap_or_else(|e| panic!("{text}: {e}"));
        let Value::Number(n) = read else { panic!("{text}: {read}") };
        let x = n.as_f64();
        assert_eq!(x.to_bits(), expected.to_bits(), "{text}");
        fast += usize::from(text.len() <= 18);
    }
    assert!(fast > 50_000, "the fast path's lengths are among them ({fast})");
}
