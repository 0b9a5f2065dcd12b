//! The web bundle (`web/dist`) and the bundled samples (`web/assets`) as they were when this
//! binary was built (`server/build.rs`), so `kloub serve` needs no files beside it.
//! The bundle is empty when `scripts/build-web.sh` had not run before the build.

use super::files::MemoryDir;
use std::sync::OnceLock;

mod tables {
    include!(concat!(env!("OUT_DIR"), "/embedded.rs"));
}

/// The embedded web bundle (hashed once per process, on first use).
pub fn dist() -> MemoryDir {
    static DIST: OnceLock<MemoryDir> = OnceLock::new();
    DIST.get_or_init(|| MemoryDir::from_static(tables::DIST)).clone()
}

/// The embedded sample library (`Fox.glb` and its licence).
pub fn assets() -> MemoryDir {
    static ASSETS: OnceLock<MemoryDir> = OnceLock::new();
    ASSETS.get_or_init(|| MemoryDir::from_static(tables::ASSETS)).clone()
}
