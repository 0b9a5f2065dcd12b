//! Which graphics backend the page asks for (`?backend=`) and how the active one is named.

/// The backend requested by the page.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// WebGPU when the browser has an adapter, else WebGL2.
    #[default]
    Auto,
    /// WebGPU only.
    WebGpu,
    /// WebGL2 only (`?backend=gl`).
    WebGl2,
}

impl BackendChoice {
    /// Parses the `backend` query value: `gl`/`webgl`/`webgl2` force WebGL2, `webgpu` forces
    /// WebGPU; anything else (or nothing) is [`BackendChoice::Auto`].
    pub fn from_query(value: Option<&str>) -> Self {
        match value.map(str::to_ascii_lowercase).as_deref() {
            Some("gl" | "webgl" | "webgl2") => Self::WebGl2,
            Some("webgpu") => Self::WebGpu,
            _ => Self::Auto,
        }
    }

    /// The wgpu instance backends for this choice (browser backends only).
    pub fn backends(self) -> wgpu::Backends {
        match self {
            Self::Auto => wgpu::Backends::BROWSER_WEBGPU | wgpu::Backends::GL,
            Self::WebGpu => wgpu::Backends::BROWSER_WEBGPU,
            Self::WebGl2 => wgpu::Backends::GL,
        }
    }
}

/// The page-contract name of an adapter's backend: `"webgpu"` or `"webgl2"` in the browser;
/// natively the wgpu name (`"vulkan"`, `"gl"`, …).
pub fn backend_name(backend: wgpu::Backend) -> &'static str {
    match backend {
        wgpu::Backend::BrowserWebGpu => "webgpu",
        wgpu::Backend::Gl if cfg!(target_arch = "wasm32") => "webgl2",
        other => other.to_str(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_values() {
        assert_eq!(BackendChoice::from_query(None), BackendChoice::Auto);
        assert_eq!(BackendChoice::from_query(Some("gl")), BackendChoice::WebGl2);
        assert_eq!(BackendChoice::from_query(Some("WebGL2")), BackendChoice::WebGl2);
        assert_eq!(BackendChoice::from_query(Some("webgpu")), BackendChoice::WebGpu);
        assert_eq!(BackendChoice::from_query(Some("vulkan")), BackendChoice::Auto);
        assert_eq!(BackendChoice::WebGl2.backends(), wgpu::Backends::GL);
        assert!(BackendChoice::Auto.backends().contains(wgpu::Backends::BROWSER_WEBGPU | wgpu::Backends::GL));
    }

    #[test]
    fn names() {
        assert_eq!(backend_name(wgpu::Backend::BrowserWebGpu), "webgpu");
        assert_eq!(backend_name(wgpu::Backend::Vulkan), "vulkan");
    }
}
