//! Import time of the characters as files are shipped: the original, gltfpack's quantized copy,
//! and its meshopt-compressed copies (`EXT_meshopt_compression` -cc, `KHR_meshopt_compression`
//! with version 1 of the attribute codec), from `tests/optimized` (scripts/make-optimized.sh).
//! Images are left encoded (as the web builds import: the browser decodes them), so the times are
//! the JSON, the accessors and the meshopt decoding.
//!
//! ```text
//! cargo bench -p kloub-core --bench import -- --warm-up-time 1 --measurement-time 3
//! ```
//! Compare the rows of one model with each other (ratios): the machine is shared and noisy.

use criterion::{Criterion, criterion_group, criterion_main};
use kloub_core::{ImportOptions, NoResolver, import};
use std::hint::black_box;
use std::path::Path;

/// (model, original file under tests/assets).
const MODELS: [(&str, &str); 3] = [
    ("Fox", "khronos/Fox/glTF-Binary/Fox.glb"),
    ("CesiumMan", "khronos/CesiumMan/glTF-Binary/CesiumMan.glb"),
    ("RobotExpressive", "threejs/RobotExpressive/RobotExpressive.glb"),
];

fn read(path: &Path) -> Option<Vec<u8>> {
    std::fs::read(path).ok()
}

fn imports(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let options = ImportOptions { decode_images: false, ..ImportOptions::default() };
    let mut group = c.benchmark_group("import");
    for (model, original) in MODELS {
        let files = [
            ("original", root.join("tests/assets").join(original)),
            ("gltfpack", root.join(format!("tests/optimized/{model}.gltfpack.glb"))),
            ("gltfpack-cc", root.join(format!("tests/optimized/{model}.gltfpack-cc.glb"))),
            ("gltfpack-khr", root.join(format!("tests/optimized/{model}.gltfpack-khr.glb"))),
        ];
        for (variant, path) in files {
            let Some(bytes) = read(&path) else { continue };
            // Only files that import are measured (an error would be a bug the tests catch).
            if import(&bytes, &NoResolver, &options).is_err() {
                continue;
            }
            group.bench_function(format!("{model}/{variant} ({} B)", bytes.len()), |b| {
                b.iter(|| black_box(import(black_box(&bytes), &NoResolver, &options)))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, imports);
criterion_main!(benches);
