//! CPU skinning throughput per method (vertices per second on one core) against the memory
//! bandwidth bound of the same data layout (`stream`).
//!
//! ```text
//! cargo bench -p kloub-core --bench skin -- --warm-up-time 1 --measurement-time 4
//! ```
//! Criterion prints `thrpt` in elements (vertices) per second. The workload is CesiumMan
//! posed mid-walk, repeated to 2^20 vertices (see `skin_workload.rs`, shared with the wasm
//! run in `wasm-bench/tests/wasm_skin.rs`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use kloub_core::NoResolver;
use kloub_core::job::dqs::SkinningMethod;
use std::path::PathBuf;

#[path = "skin_workload.rs"]
#[allow(dead_code)]
mod skin_workload;
use skin_workload::{VERTICES, Workload};

fn skin(c: &mut Criterion) {
    let dir = std::env::var_os("KLOUB_SHARED_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/assets"));
    let bytes = std::fs::read(dir.join("khronos/CesiumMan/glTF-Binary/CesiumMan.glb")).expect("CesiumMan.glb");
    let asset = kloub_core::import(&bytes, &NoResolver, &Default::default()).expect("imports").asset;
    let mut work = Workload::new(&asset);
    let mut group = c.benchmark_group("skin");
    group.throughput(Throughput::Elements(VERTICES as u64));
    group.sample_size(20);
    group.bench_function("stream", |b| b.iter(|| work.stream()));
    for method in SkinningMethod::ALL {
        group.bench_function(method.name(), |b| b.iter(|| work.skin(method)));
    }
    group.finish();
}

criterion_group!(benches, skin);
criterion_main!(benches);
