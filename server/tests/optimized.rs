//! `kloub pose` on every optimized copy in tests/optimized (gltfpack, glTF Transform: quantized,
//! meshopt, Draco, WebP) against its original: the deformed world-space vertices of every frame
//! agree within the copy's quantization error. Encoders reorder and split vertices, so the two
//! sets are compared as sets (Hausdorff distance), relative to the original's size.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Each copy, its original, and the largest Hausdorff distance accepted, as a fraction of the
/// original's bounding-box diagonal over the frames at [`TIMES`] (measured with gltfpack 1.3.0
/// and glTF Transform 4.5.1 in the comment: the bound sits above it, from each tool's
/// quantization). gltfpack quantizes positions to 14 bits and resamples animations at 30 Hz
/// (the largest part of its error on CesiumMan and RobotExpressive, whose keys are denser or
/// off that grid); `-cc` adds its filters; glTF Transform's Draco quantizes positions to 14
/// bits and leaves animations alone; WebP leaves the geometry untouched.
const COPIES: &[(&str, &str, f64)] = &[
    ("Fox.gltfpack.glb", FOX, 1e-4),                         // 6.6e-5
    ("Fox.gltfpack-c.glb", FOX, 1e-4),                       // 6.6e-5
    ("Fox.gltfpack-cc.glb", FOX, 5e-4),                      // 3.1e-4
    ("Fox.gltfpack-khr.glb", FOX, 5e-4),                     // 3.1e-4
    ("Fox.draco.glb", FOX, 1e-4),                            // 4.3e-5
    ("Fox.webp.glb", FOX, 0.0),                              // 0
    ("CesiumMan.gltfpack.glb", CESIUM_MAN, 1e-3),            // 4.6e-4
    ("CesiumMan.gltfpack-cc.glb", CESIUM_MAN, 1e-3),         // 4.7e-4
    ("CesiumMan.gltfpack-khr.glb", CESIUM_MAN, 1e-3),        // 4.7e-4
    ("CesiumMan.draco.glb", CESIUM_MAN, 1e-4),               // 5.3e-5
    ("CesiumMan.webp.glb", CESIUM_MAN, 0.0),                 // 0
    ("RobotExpressive.gltfpack.glb", ROBOT, 2e-3),           // 1.3e-3
    ("RobotExpressive.gltfpack-cc.glb", ROBOT, 2e-3),        // 1.3e-3
    ("RobotExpressive.draco.glb", ROBOT, 1e-4),              // 2.2e-5
    ("AnimatedMorphCube.gltfpack.glb", MORPH_CUBE, 1e-3),    // 4.9e-4
    ("AnimatedMorphCube.gltfpack-cc.glb", MORPH_CUBE, 1e-3), // 4.9e-4
    ("AnimatedMorphCube.draco.glb", MORPH_CUBE, 1e-4),       // 4.3e-7
    // The Khronos sample's own Draco copy (an older encoder and bitstream, 2.2).
    ("../assets/khronos/RiggedSimple/glTF-Draco/RiggedSimple.gltf", RIGGED_SIMPLE, 1e-3), // 3.6e-4
];
const FOX: &str = "khronos/Fox/glTF-Binary/Fox.glb";
const CESIUM_MAN: &str = "khronos/CesiumMan/glTF-Binary/CesiumMan.glb";
const ROBOT: &str = "threejs/RobotExpressive/RobotExpressive.glb";
const MORPH_CUBE: &str = "khronos/AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb";
const RIGGED_SIMPLE: &str = "khronos/RiggedSimple/glTF/RiggedSimple.gltf";
const TIMES: [&str; 3] = ["0", "0.37", "0.81"];

/// The deformed vertices of every primitive, per frame, from `kloub pose`.
fn pose(file: &Path) -> Vec<Vec<[f64; 3]>> {
    let mut command = Command::new(env!("CARGO_BIN_EXE_kloub"));
    command.arg("pose").arg(file);
    for t in TIMES {
        command.args(["--time", t]);
    }
    let out = command.output().expect("runs");
    assert!(out.status.success(), "{}: {}", file.display(), String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let frames = doc["frames"].as_array().expect("frames");
    frames
        .iter()
        .map(|frame| {
            let mut points = Vec::new();
            for p in frame["primitives"].as_array().expect("primitives") {
                let values: Vec<f64> =
                    p["positions"].as_array().expect("positions").iter().map(|v| v.as_f64().expect("number")).collect();
                points.extend(values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            }
            points
        })
        .collect()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The largest distance from a point of `from` to its nearest point of `to`: a grid of `cell`
/// finds the nearest within one cell, a scan of all points the rare farther ones.
fn directed(from: &[[f64; 3]], to: &[[f64; 3]], cell: f64) -> f64 {
    let key = |p: [f64; 3]| p.map(|x| (x / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, &p) in to.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let mut worst = 0.0f64;
    for &p in from {
        let k = key(p);
        let mut best = f64::INFINITY;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &i in grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]).map_or(&[][..], Vec::as_slice) {
                        best = best.min(distance(p, to[i]));
                    }
                }
            }
        }
        if best > cell {
            best = to.iter().map(|&q| distance(p, q)).fold(f64::INFINITY, f64::min);
        }
        worst = worst.max(best);
    }
    worst
}

#[test]
fn pose_of_every_optimized_copy_matches_its_original_within_its_quantization() {
    let mut report = Vec::new();
    let mut failures = Vec::new();
    let mut originals: HashMap<&str, Vec<Vec<[f64; 3]>>> = HashMap::new();
    for &(copy, original, bound) in COPIES {
        let a = originals.entry(original).or_insert_with(|| pose(&repo().join("tests/assets").join(original)));
        let b = pose(&repo().join("tests/optimized").join(copy));
        assert_eq!(a.len(), b.len(), "{copy}: frames");
        let mut worst = 0.0f64;
        for (pa, pb) in a.iter().zip(&b) {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for p in pa {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let diagonal = distance(lo, hi);
            let cell = diagonal / 256.0;
            let hausdorff = directed(pa, pb, cell).max(directed(pb, pa, cell));
            worst = worst.max(hausdorff / diagonal);
        }
        report.push(format!("{copy}: {worst:.2e} of the diagonal (bound {bound:.0e})"));
        if worst > bound {
            failures.push(format!("{copy}: {worst:.3e} > {bound:.0e}"));
        }
    }
    eprintln!("{}", report.join("\n"));
    assert!(failures.is_empty(), "{failures:#?}");
}
