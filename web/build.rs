//! The WGSL shaders (`shaders/*.wgsl`) as the renderer embeds them: without their comments,
//! indentation and blank lines (they are a fifth of the widget's download otherwise). Each line
//! keeps its place in a statement; WGSL has no string literals, and the shaders use no block
//! comments, so a `//` always starts a comment. `render::pipelines` includes the copies from
//! `OUT_DIR`; `tests/shaders.rs` validates those same strings with naga.

use std::fmt::Write as _;

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed={}", root.display());
    let mut names: Vec<_> = std::fs::read_dir(&root)
        .expect("shaders/")
        .map(|e| e.expect("a shaders/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "wgsl"))
        .collect();
    names.sort();
    for path in names {
        println!("cargo:rerun-if-changed={}", path.display());
        let source = std::fs::read_to_string(&path).expect("a WGSL file");
        assert!(!source.contains("/*"), "{}: a block comment (the build strips line comments only)", path.display());
        let mut stripped = String::with_capacity(source.len() / 2);
        for line in source.lines() {
            let code = line.split("//").next().unwrap_or("").trim();
            if !code.is_empty() {
                let _ = writeln!(stripped, "{code}");
            }
        }
        let name = path.file_name().expect("a file name");
        std::fs::write(out.join(name), stripped).expect("writing the stripped shader");
    }
}
