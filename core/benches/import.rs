//! Draco and meshopt decoding speed and import time against three.js, native (see
//! `import_cases.rs`): decoded MB/s of each compressed copy in tests/optimized, and
//! milliseconds per import of each character and its copies without images. Part of
//! `scripts/bench-import.sh`, which also runs the same cases as wasm in Node and three.js and
//! the reference decoders from npm.
//!
//! ```text
//! cargo bench -p kloub-core --bench import [-- FILTER]   # FILTER: part of a codec, variant or file name
//! ```

#[path = "import_cases.rs"]
mod import_cases;

fn main() {
    let start = std::time::Instant::now();
    let now = || start.elapsed().as_secs_f64() * 1000.0;
    let filter: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let wanted = |case: &import_cases::Case| {
        filter.iter().all(|f| case.codec.contains(f.as_str()) || case.name.contains(f.as_str()))
    };
    let decode_cases: Vec<_> = import_cases::decode_cases().into_iter().filter(|c| wanted(c)).collect();
    import_cases::warm_up(&decode_cases, 200.0, &now);
    for case in &decode_cases {
        let rate = |ms: f64| case.decoded as f64 / (ms / 1000.0) / 1e6;
        let (streams, imported) = (import_cases::measure_streams(case, &now), import_cases::measure(case, &now));
        println!("decode native {} {} {} B: {:.1} MB/s", case.codec, case.name, case.decoded, rate(streams));
        println!("imported native {} {} {} B: {:.1} MB/s", case.codec, case.name, case.decoded, rate(imported));
    }
    if std::env::var_os("KLOUB_BENCH_VIEWS").is_some() {
        for case in import_cases::decode_cases().iter().filter(|c| c.codec == "meshopt" && wanted(c)) {
            for (view, ms) in import_cases::measure_views(case, &now) {
                println!("view native {} {view}: {:.2} us", case.name, ms * 1000.0);
            }
        }
    }
    let imports: Vec<_> = import_cases::import_cases()
        .into_iter()
        .filter(|c| wanted(c) && std::env::var_os("DECODE_ONLY").is_none())
        .collect();
    import_cases::warm_up(&imports, 200.0, &now);
    for case in &imports {
        let ms = import_cases::measure(case, &now);
        println!("import native {} {} {} B: {ms:.3} ms", case.codec, case.name, case.glb.len());
    }
}
