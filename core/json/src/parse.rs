//! The parser: RFC 8259 JSON, one pass over the bytes, into the arena's tree.
//!
//! It reads what serde_json reads and refuses what it refuses (127 nested arrays and objects at
//! most, lone surrogates, numbers beyond `f64`), with its messages' words and positions ("… at
//! line L column C"); `tests/serde_agreement.rs` holds it to that. It was written for speed in
//! wasm, where serde_json's parse of a small character's JSON into this tree was a fifth of its
//! import (BENCHMARKS.md, "Import and decoding", stop 63): one loop over the values (no call and
//! no recursion per value), each value pushed where it is read, an error kept in the parser
//! instead of carried back through every call, integers and plain fractions read in one pass (a
//! long float kept as its text, read when asked for), a string's plain bytes eight at a time.

use crate::{Map, Number, Value};
use std::cell::Cell;
use std::fmt;

/// Why a document is not JSON, and where: the byte, its line and column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    message: &'static str,
    /// The byte's offset in the document.
    offset: usize,
    line: usize,
    column: usize,
}

impl Error {
    /// What is wrong ("expected value", "trailing comma", …).
    pub fn message(&self) -> &'static str {
        self.message
    }

    /// The line (from 1).
    pub fn line(&self) -> usize {
        self.line
    }

    /// The column in bytes, as serde_json counts it: that of the byte's end (so 0 for an empty
    /// document).
    pub fn column(&self) -> usize {
        self.column
    }

    /// The offset of the byte where it was found.
    pub fn offset(&self) -> usize {
        self.offset
    }

    /// An error at the byte at `offset`, written as serde_json writes it: the line and column
    /// of its end (so column 0 for an empty document, and the line after a newline).
    fn at(bytes: &[u8], offset: usize, message: &'static str) -> Self {
        let end = (offset + 1).min(bytes.len());
        let before = bytes.get(..end).unwrap_or(bytes);
        let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
        let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        Error { message, offset, line, column: end - line_start }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at line {} column {}", self.message, self.line, self.column)
    }
}

impl std::error::Error for Error {}

/// serde_json's recursion limit: 127 arrays and objects nested at most (this parser keeps them
/// on a stack, not the call stack, and refuses what serde_json refuses).
const NESTING_LIMIT: usize = 127;

/// Parses `bytes` (as `crate::parse_counted`).
pub(crate) fn parse<'j>(bytes: &'j [u8], arena: &'j bumpalo::Bump) -> Result<(Value<'j>, u64), Error> {
    // Valid UTF-8 as a whole (checked in one vectorized pass): a string is then a slice of the
    // text wherever it starts and ends at a quote. Otherwise each string is checked as it is
    // read, so that the first error in the document is the one reported.
    let text = std::str::from_utf8(bytes).ok();
    let mut parser = Parser {
        text,
        bytes,
        pos: 0,
        arena,
        items: Vec::new(),
        keys: Vec::new(),
        fault: Cell::default(),
        unescaped: Vec::new(),
        nested: 0,
    };
    let parsed = parser.document().and_then(|()| {
        parser.skip_whitespace();
        match parser.items.pop() {
            Some(value) if parser.pos == bytes.len() => Ok(value),
            _ => Err(parser.error("trailing characters")),
        }
    });
    match parsed {
        Ok(value) => Ok((value, 1 + parser.nested)),
        Err(Stop) => {
            let Fault { message, offset, back } = parser.fault.get();
            let mut e = Error::at(bytes, offset, message);
            e.column = e.column.saturating_sub(back);
            Err(e)
        }
    }
}

/// The parse has stopped: why is in [`Parser::fault`] (a result of nothing but this is returned
/// in a register, where one carrying the error was written to memory and read back).
struct Stop;

/// An [`Error`] as the parser keeps it: its line and column are counted once, at the top.
#[derive(Clone, Copy, Default)]
struct Fault {
    message: &'static str,
    offset: usize,
    /// Bytes back from the offset's column ([`Parser::invalid_utf8`]).
    back: usize,
}

/// Whether a byte ends a string's plain run: a quote, a backslash or a control character.
static STRING_STOP: [bool; 256] = {
    let mut stop = [false; 256];
    let mut b = 0;
    while b < 0x20 {
        stop[b] = true;
        b += 1;
    }
    stop[b'"' as usize] = true;
    stop[b'\\' as usize] = true;
    stop
};

/// Where the run of a string's bytes from `pos` that need no attention ends: eight bytes at a
/// time while none of them is a quote, a backslash or a control character.
fn plain_run(bytes: &[u8], mut pos: usize) -> usize {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const HIGHS: u64 = 0x8080_8080_8080_8080;
    while let Some(chunk) = bytes.get(pos..pos + 8) {
        let mut eight = [0; 8];
        eight.copy_from_slice(chunk);
        let x = u64::from_le_bytes(eight);
        // A byte below 0x20, or equal to '"' or '\\', sets its high bit in one of these (the
        // classic "has a zero byte" test; a byte of 0x80 or more sets none, as it must).
        let control = x.wrapping_sub(ONES * 0x20);
        let quote = (x ^ (ONES * u64::from(b'"'))).wrapping_sub(ONES);
        let backslash = (x ^ (ONES * u64::from(b'\\'))).wrapping_sub(ONES);
        if (control | quote | backslash) & !x & HIGHS != 0 {
            break;
        }
        pos += 8;
    }
    pos
}

/// An integer of magnitude `n` as serde_json reads it: `U` from 0, `I` below 0; `None` where it
/// is a float (`-0`, or below `i64`).
fn integer(n: u64, negative: bool) -> Option<Number<'static>> {
    match (negative, n) {
        (false, n) => Some(Number::U(n)),
        (true, 1..=0x8000_0000_0000_0000) => Some(Number::I(0i64.wrapping_sub_unsigned(n))),
        (true, _) => None,
    }
}

/// `significand × 10^scale` (negated where `negative`) where Clinger's fast path reads it: a
/// significand below 2^53 and a power of ten up to 10^22 are both exact in `f64`, so one
/// multiplication or division rounds once, correctly (serde_json reads such a number the same
/// way).
fn exact(significand: u64, scale: i64, negative: bool) -> Option<f64> {
    if significand >= 1 << 53 {
        return None;
    }
    let power = POW10.get(usize::try_from(scale.unsigned_abs()).ok()?)?;
    let m = significand as f64;
    let x = if scale < 0 { m / power } else { m * power };
    Some(if negative { -x } else { x })
}

/// 10^0 ..= 10^22, every one exact in `f64`.
static POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

struct Parser<'j> {
    /// The document, where it is valid UTF-8 as a whole.
    text: Option<&'j str>,
    bytes: &'j [u8],
    pos: usize,
    arena: &'j bumpalo::Bump,
    /// The values of the arrays and objects being parsed, and the objects' keys, as stacks: each
    /// value is pushed where it is parsed, and each array or object is copied out into a slice
    /// of its exact size in the arena once complete (no vector grows item by item).
    items: Vec<Value<'j>>,
    keys: Vec<&'j str>,
    /// Why the parse stopped, once it has ([`Stop`]).
    fault: Cell<Fault>,
    /// A string with escapes, as it is unescaped (then copied into the arena).
    unescaped: Vec<u8>,
    /// The items and members parsed so far (every value but the root).
    nested: u64,
}

/// An array or object being parsed: where its items (and keys) start on the stacks.
#[derive(Clone, Copy)]
struct Open {
    object: bool,
    items: usize,
    keys: usize,
}

impl<'j> Parser<'j> {
    /// Stops the parse for `message` at the byte at `offset`.
    #[cold]
    fn fail(&self, offset: usize, message: &'static str) -> Stop {
        self.fault.set(Fault { message, offset, back: 0 });
        Stop
    }

    /// Stops the parse for `message` at the current byte.
    fn error(&self, message: &'static str) -> Stop {
        self.fail(self.pos, message)
    }

    /// A string's text is not UTF-8: reported at its closing quote (at `self.pos`), `back` bytes
    /// before it in the column (serde_json's "first invalid byte", approximate after escapes).
    fn invalid_utf8(&self, back: usize) -> Stop {
        self.fault.set(Fault { message: "invalid unicode code point", offset: self.pos, back });
        Stop
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn skip_whitespace(&mut self) {
        while let Some(b' ' | b'\n' | b'\r' | b'\t') = self.bytes.get(self.pos) {
            self.pos += 1;
        }
    }

    /// The document's value, pushed onto `items`: one loop over the values, the arrays and
    /// objects open around the one being read kept in `open` (a call per value, recursing
    /// into each array and object, was a good part of the parse in wasm).
    fn document(&mut self) -> Result<(), Stop> {
        let mut open: Vec<Open> = Vec::new();
        'value: loop {
            self.skip_whitespace();
            let value = match self.peek() {
                Some(b'"') => {
                    self.pos += 1;
                    Value::String(self.string()?)
                }
                Some(b'-' | b'0'..=b'9') => Value::Number(self.number()?),
                Some(bracket @ (b'{' | b'[')) => {
                    if open.len() >= NESTING_LIMIT {
                        return Err(self.error("recursion limit exceeded"));
                    }
                    self.pos += 1;
                    let object = bracket == b'{';
                    open.push(Open { object, items: self.items.len(), keys: self.keys.len() });
                    self.skip_whitespace();
                    if self.peek() != Some(if object { b'}' } else { b']' }) {
                        if object {
                            self.key()?;
                        }
                        continue 'value;
                    }
                    self.pos += 1;
                    self.close(&mut open)
                }
                Some(b't') => self.literal(b"true", Value::Bool(true))?,
                Some(b'f') => self.literal(b"false", Value::Bool(false))?,
                Some(b'n') => self.literal(b"null", Value::Null)?,
                Some(_) => return Err(self.error("expected value")),
                None => return Err(self.error("EOF while parsing a value")),
            };
            self.items.push(value);
            // A value is complete: what follows it in the array or object around it, where
            // each that it closes is complete in turn.
            loop {
                let Some(&Open { object, .. }) = open.last() else { return Ok(()) };
                self.skip_whitespace();
                match self.peek() {
                    Some(b',') => {
                        self.pos += 1;
                        self.skip_whitespace();
                        if self.peek() == Some(if object { b'}' } else { b']' }) {
                            return Err(self.error("trailing comma"));
                        }
                        if object {
                            self.key()?;
                        }
                        continue 'value;
                    }
                    Some(b']') if !object => {}
                    Some(b'}') if object => {}
                    Some(_) if object => return Err(self.error("expected `,` or `}`")),
                    Some(_) => return Err(self.error("expected `,` or `]`")),
                    None if object => return Err(self.error("EOF while parsing an object")),
                    None => return Err(self.error("EOF while parsing a list")),
                }
                self.pos += 1;
                let closed = self.close(&mut open);
                self.items.push(closed);
            }
        }
    }

    /// An object's member's key and colon, up to its value.
    #[inline(always)]
    fn key(&mut self) -> Result<(), Stop> {
        match self.peek() {
            Some(b'"') => self.pos += 1,
            Some(_) => return Err(self.error("key must be a string")),
            None => return Err(self.error("EOF while parsing an object")),
        }
        let key = self.string()?;
        self.keys.push(key);
        self.skip_whitespace();
        match self.peek() {
            Some(b':') => {
                self.pos += 1;
                Ok(())
            }
            Some(_) => Err(self.error("expected `:`")),
            None => Err(self.error("EOF while parsing an object")),
        }
    }

    /// The innermost open array or object, its closing bracket read: its items (and keys) taken
    /// off the stacks into the arena.
    #[inline(always)]
    fn close(&mut self, open: &mut Vec<Open>) -> Value<'j> {
        let Some(Open { object, items, keys }) = open.pop() else { return Value::Null };
        let values = self.items.get(items..).unwrap_or_default();
        self.nested += values.len() as u64;
        let value = if object {
            let names = self.keys.get(keys..).unwrap_or_default();
            Value::Object(Map::from_members(names, values, self.arena))
        } else {
            Value::Array(self.arena.alloc_slice_copy(values))
        };
        self.items.truncate(items);
        self.keys.truncate(keys);
        value
    }

    fn literal(&mut self, word: &[u8], value: Value<'j>) -> Result<Value<'j>, Stop> {
        for &expected in word {
            match self.peek() {
                Some(b) if b == expected => self.pos += 1,
                Some(_) => return Err(self.error("expected ident")),
                None => return Err(self.error("EOF while parsing a value")),
            }
        }
        Ok(value)
    }

    /// A string, its opening quote read: borrowed from the text where it has no escapes.
    fn string(&mut self) -> Result<&'j str, Stop> {
        let start = self.pos;
        self.pos = plain_run(self.bytes, start);
        loop {
            let Some(&b) = self.bytes.get(self.pos) else {
                return Err(self.error("EOF while parsing a string"));
            };
            if !STRING_STOP[usize::from(b)] {
                self.pos += 1;
                continue;
            }
            return match b {
                b'"' => {
                    let s = match self.text {
                        Some(text) => text.get(start..self.pos).ok_or_else(|| self.error("invalid unicode code point")),
                        None => {
                            let raw = self.bytes.get(start..self.pos).unwrap_or_default();
                            std::str::from_utf8(raw).map_err(|e| self.invalid_utf8(raw.len() - e.valid_up_to()))
                        }
                    }?;
                    self.pos += 1;
                    Ok(s)
                }
                b'\\' => self.escaped_string(start),
                _ => Err(self.error("control character (\\u0000-\\u001F) found while parsing a string")),
            };
        }
    }

    /// The rest of a string that has an escape at `self.pos` (its text from `start`), unescaped
    /// and copied into the arena.
    fn escaped_string(&mut self, start: usize) -> Result<&'j str, Stop> {
        self.unescaped.clear();
        self.unescaped.extend_from_slice(self.bytes.get(start..self.pos).unwrap_or_default());
        loop {
            let Some(&b) = self.bytes.get(self.pos) else {
                return Err(self.error("EOF while parsing a string"));
            };
            self.pos += 1;
            match b {
                b'"' => break,
                b'\\' => self.escape()?,
                b if b < 0x20 => {
                    self.pos -= 1;
                    return Err(self.error("control character (\\u0000-\\u001F) found while parsing a string"));
                }
                b => self.unescaped.push(b),
            }
        }
        // Escapes write whole characters and the rest is copied from valid UTF-8 between ASCII
        // bytes, so this holds; checked anyway rather than assumed.
        match std::str::from_utf8(&self.unescaped) {
            Ok(s) => Ok(self.arena.alloc_str(s)),
            Err(e) => {
                let back = self.unescaped.len() - e.valid_up_to();
                self.pos -= 1;
                Err(self.invalid_utf8(back))
            }
        }
    }

    /// One escape, its backslash read.
    fn escape(&mut self) -> Result<(), Stop> {
        let Some(&b) = self.bytes.get(self.pos) else {
            return Err(self.error("EOF while parsing a string"));
        };
        self.pos += 1;
        let byte = match b {
            b'"' => b'"',
            b'\\' => b'\\',
            b'/' => b'/',
            b'b' => 0x08,
            b'f' => 0x0c,
            b'n' => b'\n',
            b'r' => b'\r',
            b't' => b'\t',
            b'u' => return self.unicode_escape(),
            _ => {
                self.pos -= 1;
                return Err(self.error("invalid escape"));
            }
        };
        self.unescaped.push(byte);
        Ok(())
    }

    /// `\uXXXX`, its `\u` read: a character, or a surrogate pair's two escapes (serde_json's
    /// reading, its errors and where it reports them).
    fn unicode_escape(&mut self) -> Result<(), Stop> {
        let first = self.hex4()?;
        let code = match first {
            0xD800..=0xDBFF => {
                for expected in [b'\\', b'u'] {
                    match self.peek() {
                        Some(b) => {
                            self.pos += 1;
                            if b != expected {
                                return Err(self.fail(self.pos - 1, "unexpected end of hex escape"));
                            }
                        }
                        None => return Err(self.error("EOF while parsing a string")),
                    }
                }
                let second = self.hex4()?;
                if !(0xDC00..=0xDFFF).contains(&second) {
                    return Err(self.fail(self.pos - 1, "lone leading surrogate in hex escape"));
                }
                0x10000 + ((u32::from(first) - 0xD800) << 10) + (u32::from(second) - 0xDC00)
            }
            0xDC00..=0xDFFF => return Err(self.fail(self.pos - 1, "lone leading surrogate in hex escape")),
            _ => u32::from(first),
        };
        let c = char::from_u32(code).ok_or_else(|| self.fail(self.pos - 1, "invalid unicode code point"))?;
        let mut utf8 = [0; 4];
        self.unescaped.extend_from_slice(c.encode_utf8(&mut utf8).as_bytes());
        Ok(())
    }

    /// Four hex digits (an error at the fourth where any is not one).
    fn hex4(&mut self) -> Result<u16, Stop> {
        let Some(digits) = self.bytes.get(self.pos..self.pos + 4) else {
            self.pos = self.bytes.len();
            return Err(self.error("EOF while parsing a string"));
        };
        self.pos += 4;
        let mut n = 0u16;
        for &b in digits {
            let digit = match b {
                b'0'..=b'9' => b - b'0',
                b'a'..=b'f' => b - b'a' + 10,
                b'A'..=b'F' => b - b'A' + 10,
                _ => return Err(self.fail(self.pos - 1, "invalid escape")),
            };
            n = (n << 4) | u16::from(digit);
        }
        Ok(n)
    }

    /// The number's text, from `start` to here (its characters are ASCII whether the document is
    /// UTF-8 or not).
    fn written(&self, start: usize) -> Result<&'j str, Stop> {
        let text = match self.text {
            Some(text) => text.get(start..self.pos),
            None => self.bytes.get(start..self.pos).and_then(|b| std::str::from_utf8(b).ok()),
        };
        text.ok_or_else(|| self.error("invalid number"))
    }

    /// One digit or more (a fraction's or an exponent's).
    fn required_digits(&mut self) -> Result<(), Stop> {
        if self.digits() > 0 {
            Ok(())
        } else if self.pos < self.bytes.len() {
            Err(self.error("invalid number"))
        } else {
            Err(self.error("EOF while parsing a value"))
        }
    }

    fn digits(&mut self) -> usize {
        let start = self.pos;
        while let Some(b'0'..=b'9') = self.bytes.get(self.pos) {
            self.pos += 1;
        }
        self.pos - start
    }

    /// A number, at its first character (`-` or a digit): an integer as `U` (from 0) or `I`
    /// (below 0) where it fits 64 bits, anything else (a fraction, an exponent, a larger
    /// integer, `-0`) as a float (`F` or `Decimal`), refused beyond `f64`'s range (serde_json's
    /// reading).
    fn number(&mut self) -> Result<Number<'j>, Stop> {
        // Most of a file's numbers are short integers (indices, counts, types): read in one pass
        // where the number is one.
        let start = self.pos;
        let digits_start = start + usize::from(self.peek() == Some(b'-'));
        let (mut end, mut n) = (digits_start, 0u64);
        while let Some(&d @ b'0'..=b'9') = self.bytes.get(end) {
            n = n.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
            end += 1;
        }
        let count = end - digits_start;
        let negative = digits_start != start;
        if count == 0 || (count > 1 && self.bytes.get(digits_start) == Some(&b'0')) {
            return self.any_number();
        }
        match self.bytes.get(end) {
            Some(b'e' | b'E') => {}
            // And most of the rest are fractions without an exponent, as exporters write them.
            Some(b'.') => {
                let fraction_start = end + 1;
                let mut fraction_end = fraction_start;
                while let Some(&d @ b'0'..=b'9') = self.bytes.get(fraction_end) {
                    n = n.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
                    fraction_end += 1;
                }
                let fraction = fraction_end - fraction_start;
                // Below 10^300 (any such number is finite), not cut short, no exponent.
                if count <= 300 && fraction > 0 && !matches!(self.bytes.get(fraction_end), Some(b'e' | b'E')) {
                    self.pos = fraction_end;
                    // `n` holds every digit where there are at most 19.
                    if count + fraction <= 19
                        && let Some(x) = exact(n, -(fraction as i64), negative)
                    {
                        return Ok(Number::F(x));
                    }
                    return self.written(start).map(Number::Decimal);
                }
            }
            // At most 19 digits: `n` holds them all.
            _ if count <= 19 => {
                if let Some(integer) = integer(n, negative) {
                    self.pos = end;
                    return Ok(integer);
                }
            }
            _ => {}
        }
        self.any_number()
    }

    /// A number as [`Parser::number`] reads it, whatever its form.
    fn any_number(&mut self) -> Result<Number<'j>, Stop> {
        let start = self.pos;
        let negative = self.peek() == Some(b'-');
        if negative {
            self.pos += 1;
        }
        // The integer part: `0` or a digit 1–9 and more digits.
        let int_start = self.pos;
        match self.peek() {
            Some(b'0') => self.pos += 1,
            Some(b'1'..=b'9') => {
                self.digits();
            }
            Some(_) => return Err(self.error("invalid number")),
            None => return Err(self.error("EOF while parsing a value")),
        }
        let int_digits = self.bytes.get(int_start..self.pos).unwrap_or_default();
        let mut fraction: &[u8] = &[];
        if self.peek() == Some(b'.') {
            self.pos += 1;
            let fraction_start = self.pos;
            self.required_digits()?;
            fraction = self.bytes.get(fraction_start..self.pos).unwrap_or_default();
        }
        let mut exponent: Option<i64> = None;
        if let Some(b'e' | b'E') = self.peek() {
            self.pos += 1;
            let exponent_negative = match self.peek() {
                Some(b'-') => {
                    self.pos += 1;
                    true
                }
                Some(b'+') => {
                    self.pos += 1;
                    false
                }
                _ => false,
            };
            let exponent_start = self.pos;
            self.required_digits()?;
            // An exponent past i32's range: a non-zero number is out of range (refused at that
            // digit, as serde_json does), any other is zero (the saturated exponent gives it).
            let mut magnitude = 0i64;
            let nonzero = int_digits.iter().chain(fraction).any(|&d| d != b'0');
            for (i, &d) in self.bytes.get(exponent_start..self.pos).unwrap_or_default().iter().enumerate() {
                magnitude = magnitude * 10 + i64::from(d - b'0');
                if magnitude > i64::from(i32::MAX) {
                    if nonzero && !exponent_negative {
                        return Err(self.fail(exponent_start + i, "number out of range"));
                    }
                    magnitude = i64::from(i32::MAX);
                    break;
                }
            }
            exponent = Some(if exponent_negative { -magnitude } else { magnitude });
        }
        // An integer here is one `number` did not take (20 digits or more, `-0`, below i64):
        // checked for overflow (a call in wasm, once per digit, on this rare path only).
        if fraction.is_empty()
            && exponent.is_none()
            && let Some(integer) = int_digits
                .iter()
                .try_fold(0u64, |n, &d| n.checked_mul(10)?.checked_add(u64::from(d - b'0')))
                .and_then(|n| integer(n, negative))
        {
            return Ok(integer);
        }
        self.float(start, negative, int_digits, fraction, exponent.unwrap_or(0))
    }

    /// The number written from `start` to here: as `f64` where that is one exact operation (as
    /// serde_json reads it), as its text (read when asked for, [`Number::Decimal`]) where it is known to be
    /// within `f64`'s range, refused where it is known not to be.
    fn float(
        &self,
        start: usize,
        negative: bool,
        int_digits: &[u8],
        fraction: &[u8],
        exponent: i64,
    ) -> Result<Number<'j>, Stop> {
        if int_digits.len() + fraction.len() <= 19 {
            let significand = int_digits.iter().chain(fraction).fold(0u64, |n, &d| n * 10 + u64::from(d - b'0'));
            if let Some(x) = exact(significand, exponent - fraction.len() as i64, negative) {
                return Ok(Number::F(x));
            }
        }
        let written = self.written(start)?;
        let out_of_range = || self.fail(self.pos - 1, "number out of range");
        // The number is in [10^e, 10^(e + 1)) for the decimal exponent e of its first digit that
        // is not 0: below 10^308 it is finite (f64's largest is 1.797e308), from 10^309 it is
        // not, and in between it is read now to tell.
        let Some(first) = int_digits.iter().chain(fraction).position(|&d| d != b'0') else {
            return Ok(Number::F(if negative { -0.0 } else { 0.0 }));
        };
        let e = int_digits.len() as i64 - 1 - first as i64 + exponent;
        if e < 308 {
            Ok(Number::Decimal(written))
        } else if e > 308 {
            Err(out_of_range())
        } else {
            match crate::read_decimal(written) {
                Some(x) if x.is_finite() => Ok(Number::F(x)),
                _ => Err(out_of_range()),
            }
        }
    }
}
