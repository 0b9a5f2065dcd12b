//! The per-frame cost of `pose` and `single` (see `frame.rs`) as the least time per frame over
//! many short batches spread over half a minute, round robin over the characters: on a shared
//! machine whose speed drifts for seconds at a time, criterion's mean moves by ±20 % between runs,
//! while the quickest batches (noise only ever adds time) repeat within a few percent.
//!
//! ```text
//! cargo bench -p kloub-core --bench frame_min
//! ```
//! Prints a Markdown table with the ratio to three.js r187 for the same work.

mod common;

use common::{CHARACTERS, Posed, THREE_JS_US, clip, instance_frame, load};
use kloub_core::{Animator, Instance};
use std::time::Instant;

/// Rounds over all characters; each measures every figure once.
const ROUNDS: usize = 60;
/// Frames per batch (a batch takes ~10–60 µs × 1000: short enough to fit a quiet moment).
const FRAMES: u32 = 1000;
/// Batches per figure per round; the least is kept.
const BATCHES: usize = 5;

/// Least µs per frame over `BATCHES` batches of `frame`.
fn least(mut frame: impl FnMut()) -> f64 {
    (0..BATCHES)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..FRAMES {
                frame();
            }
            start.elapsed().as_secs_f64() * 1e6 / f64::from(FRAMES)
        })
        .fold(f64::INFINITY, f64::min)
}

struct Character {
    name: &'static str,
    asset: kloub_core::asset::Asset,
    posed: Posed,
    pose_animator: Animator,
    single_animator: Animator,
    instance: Instance,
    best: [f64; 2],
}

fn main() {
    let mut characters: Vec<Character> = CHARACTERS
        .iter()
        .map(|&(name, file, base, ..)| {
            let asset = load(file);
            let base = clip(&asset, base);
            let animator = || {
                let mut a = Animator::new(&asset);
                a.play(&asset, Some(base)).expect("valid");
                a
            };
            let (pose_animator, single_animator) = (animator(), animator());
            Character {
                name,
                posed: Posed::new(&asset),
                instance: Instance::new(&asset),
                pose_animator,
                single_animator,
                asset,
                best: [f64::INFINITY; 2],
            }
        })
        .collect();
    for _ in 0..ROUNDS {
        for c in &mut characters {
            let (asset, posed, animator) = (&c.asset, &mut c.posed, &mut c.pose_animator);
            c.best[0] = c.best[0].min(least(|| posed.frame(asset, animator)));
            let (animator, instance) = (&mut c.single_animator, &mut c.instance);
            c.best[1] = c.best[1].min(least(|| instance_frame(asset, animator, instance)));
        }
    }
    println!("| Character | `pose` | `single` | three.js r187 | `pose` vs three.js |");
    println!("|---|---:|---:|---:|---:|");
    for (c, three) in characters.iter().zip(THREE_JS_US) {
        let [pose, single] = c.best;
        println!("| {} | {pose:.3} µs | {single:.3} µs | ~{three} µs | {:.1}× |", c.name, three / pose);
    }
}
