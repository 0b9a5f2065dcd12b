//! Exact `Content-Type` values by file extension.

use std::path::Path;

/// `Content-Type` of a file served by `kloub serve`, from its extension (case-insensitive).
/// Unknown extensions are `application/octet-stream`, which browsers never render inline.
pub fn content_type(path: &Path) -> &'static str {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "html" | "htm" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript",
        "wasm" => "application/wasm",
        "css" => "text/css; charset=utf-8",
        "json" | "map" => "application/json",
        "glb" => "model/gltf-binary",
        "gltf" => "model/gltf+json",
        "bin" => "application/octet-stream",
        "png" => "image/png",
        "jpg" | "jpeg" => "image/jpeg",
        "webp" => "image/webp",
        "ktx2" => "image/ktx2",
        "svg" => "image/svg+xml",
        "ico" => "image/x-icon",
        "txt" | "md" => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::content_type;
    use std::path::Path;

    #[test]
    fn exact_types() {
        let cases = [
            ("kloub_web_bg.wasm", "application/wasm"),
            ("kloub_web.js", "text/javascript"),
            ("index.html", "text/html; charset=utf-8"),
            ("Fox.glb", "model/gltf-binary"),
            ("Fox.gltf", "model/gltf+json"),
            ("Fox.bin", "application/octet-stream"),
            ("Texture.png", "image/png"),
            ("a.jpg", "image/jpeg"),
            ("a.jpeg", "image/jpeg"),
            ("a.json", "application/json"),
            ("style.css", "text/css; charset=utf-8"),
            ("UPPER.WASM", "application/wasm"),
            ("no_extension", "application/octet-stream"),
            ("weird.exe", "application/octet-stream"),
        ];
        for (name, want) in cases {
            assert_eq!(content_type(Path::new(name)), want, "{name}");
        }
    }
}
