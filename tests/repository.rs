//! The repository alone is the product: every asset the tests, benchmarks and the sample library
//! use is inside it, intact, and nothing reads files from beside the checkout.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    kloub_tests::repo_root()
}

/// Every file listed in `tests/assets/SHA256SUMS` is in the repository with its exact contents.
#[test]
fn the_test_assets_are_in_the_repository_and_intact() {
    let dir = repo().join("tests/assets");
    let sums = std::fs::read_to_string(dir.join("SHA256SUMS")).expect("tests/assets/SHA256SUMS");
    let mut checked = 0;
    for line in sums.lines().filter(|l| !l.trim().is_empty()) {
        let (sum, name) = line.split_once("  ").unwrap_or_else(|| panic!("malformed line {line:?}"));
        let bytes = std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("tests/assets/{name}: {e}"));
        let got: String = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(got, sum, "tests/assets/{name} differs from its checksum");
        checked += 1;
    }
    assert!(checked > 100, "only {checked} files listed");
}

/// Each bundled sample of the library is byte-identical to its test-asset copy (git stores it once)
/// and has its licence file beside it.
#[test]
fn the_sample_library_is_the_test_assets_with_licences() {
    for (sample, asset) in [
        ("Fox.glb", "khronos/Fox/glTF-Binary/Fox.glb"),
        ("CesiumMan/CesiumMan.glb", "khronos/CesiumMan/glTF-Binary/CesiumMan.glb"),
        ("RiggedFigure/RiggedFigure.glb", "khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb"),
        ("RobotExpressive/RobotExpressive.glb", "threejs/RobotExpressive/RobotExpressive.glb"),
        ("Knight/Knight.glb", "kaykit/Knight/Knight.glb"),
        (
            "AnimatedMorphSphere/AnimatedMorphSphere.glb",
            "khronos/AnimatedMorphSphere/glTF-Binary/AnimatedMorphSphere.glb",
        ),
    ] {
        let read = |p: &Path| std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let library = repo().join("web/assets");
        assert!(read(&library.join(sample)) == read(&repo().join("tests/assets").join(asset)), "{sample} != {asset}");
        let licence = library.join(sample.replace(".glb", ".LICENSE.md"));
        assert!(licence.is_file(), "{} missing", licence.display());
    }
}

/// Source files that name a path outside the checkout: a fresh clone would not have it.
#[test]
fn no_source_reads_beside_the_checkout() {
    let mut offenders = Vec::new();
    for top in ["core", "server", "web", "tests", "scripts", ".ci"] {
        scan(&repo().join(top), &mut offenders);
    }
    assert!(offenders.is_empty(), "paths outside the repository in: {offenders:#?}");
}

fn scan(dir: &Path, offenders: &mut Vec<String>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if !matches!(name.as_str(), "target" | "node_modules" | "dist" | "out" | "assets" | "golden") {
                scan(&path, offenders);
            }
            continue;
        }
        let code = ["rs", "mjs", "js", "sh", "py", "toml", "html"].iter().any(|e| name.ends_with(&format!(".{e}")))
            || name == "run";
        if !code || path.ends_with("tests/repository.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        for needle in ["../shared", "shared/assets"] {
            if text.contains(needle) {
                offenders.push(format!("{} ({needle})", path.display()));
            }
        }
    }
}
