//! A tiny `log` backend writing structured lines (logfmt) to stderr:
//!
//! ```text
//! ts=2025-01-31T12:00:00.123Z level=info target=kloub_server::serve msg="asset index: 1 model(s)"
//! ts=2025-01-31T12:00:00.456Z level=info target=access method=GET path="/" status=200 bytes=632 ms=0.21
//! ```
//! Records with target [`ACCESS`] carry ready-made `key=value` fields (one line per request,
//! [`crate::serve`]); any other message is quoted into `msg`.
//! The level comes from `KLOUB_LOG` (`off`, `error`, `warn`, `info`, `debug`, `trace`; default `info`).

use log::{LevelFilter, Log, Metadata, Record};
use std::fmt::Write as _;
use std::io::Write;
use std::time::{SystemTime, UNIX_EPOCH};

/// Log target of the per-request lines, whose message is already `key=value` fields.
pub const ACCESS: &str = "access";

struct StderrLogger;

impl Log for StderrLogger {
    fn enabled(&self, metadata: &Metadata) -> bool {
        metadata.level() <= log::max_level()
    }

    fn log(&self, record: &Record) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let mut line = format!(
            "ts={} level={} target={}",
            timestamp(SystemTime::now()),
            record.level().as_str().to_ascii_lowercase(),
            record.target()
        );
        if record.target() == ACCESS {
            let _ = write!(line, " {}", record.args());
        } else {
            line.push_str(" msg=");
            quote_into(&mut line, &record.args().to_string());
        }
        line.push('\n');
        // One write per line keeps lines whole; a failed write to stderr has nowhere to go.
        let _ = std::io::stderr().lock().write_all(line.as_bytes());
    }

    fn flush(&self) {
        let _ = std::io::stderr().flush();
    }
}

static LOGGER: StderrLogger = StderrLogger;

/// Installs the stderr logger (once; later calls change nothing) at the level of `KLOUB_LOG`.
pub fn init() {
    let level =
        std::env::var("KLOUB_LOG").ok().and_then(|v| v.parse::<LevelFilter>().ok()).unwrap_or(LevelFilter::Info);
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(level);
    }
}

/// Appends `text` as a logfmt quoted value: `"` and `\` escaped, control characters as `\xNN`.
pub fn quote_into(out: &mut String, text: &str) {
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c if c.is_control() => {
                let _ = write!(out, "\\x{:02x}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// RFC 3339 UTC time with milliseconds, e.g. `2025-01-31T12:00:00.123Z`.
pub fn timestamp(t: SystemTime) -> String {
    let since = t.duration_since(UNIX_EPOCH).unwrap_or_default();
    let secs = since.as_secs();
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm), valid for any u64 day count here.
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z % 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + u64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60,
        since.subsec_millis()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn timestamps_are_rfc3339_utc() {
        assert_eq!(timestamp(UNIX_EPOCH), "1970-01-01T00:00:00.000Z");
        let t = UNIX_EPOCH + Duration::from_millis(951_782_400_000 + 3_723_456);
        assert_eq!(timestamp(t), "2000-02-29T01:02:03.456Z");
        let t = UNIX_EPOCH + Duration::from_secs(1_735_689_599);
        assert_eq!(timestamp(t), "2024-12-31T23:59:59.000Z");
    }

    #[test]
    fn quoting_escapes() {
        let mut s = String::new();
        quote_into(&mut s, "a \"b\" \\ c\nd\u{7}");
        assert_eq!(s, r#""a \"b\" \\ c\nd\x07""#);
    }
}
