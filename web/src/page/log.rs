//! `log` records on the browser console: info and above in the full app; warnings and errors only
//! in the widget builds, which live on other people's pages (and whose every console line, before
//! the first frame, is time a page waits: a few ms each where the console is inspected).

struct Console;

/// The most verbose level written.
const LEVEL: log::LevelFilter = if cfg!(feature = "full") { log::LevelFilter::Info } else { log::LevelFilter::Warn };

impl log::Log for Console {
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        metadata.level() <= LEVEL
    }

    fn log(&self, record: &log::Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let text = wasm_bindgen::JsValue::from_str(&record.args().to_string());
        match record.level() {
            log::Level::Error => web_sys::console::error_1(&text),
            log::Level::Warn => web_sys::console::warn_1(&text),
            _ => web_sys::console::log_1(&text),
        }
    }

    fn flush(&self) {}
}

static CONSOLE: Console = Console;

/// Installs the console logger (once; later calls do nothing).
pub fn init() {
    if log::set_logger(&CONSOLE).is_ok() {
        log::set_max_level(LEVEL);
    }
}
