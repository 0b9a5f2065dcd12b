//! Prints the candy-wrapper quality tables of BENCHMARKS.md: volume ratio to rest under bend
//! and radius kept at the joint under twist, for every skinning method (CPU reference; `sjbbe`
//! with the rig's example pose).
//!
//! `cargo run --release -p kloub-core --example candy_wrapper`

use kloub_core::Instance;
use kloub_core::candy::CandyWrapper;
use kloub_core::job::dqs::SkinningMethod;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let rig = CandyWrapper::new();
    let mut instance = Instance::new(&rig.asset);
    // sjbbe: the rig's example pose (Joint bent 90°, a bulge keeping the volume there).
    instance.set_examples(&rig.asset, rig.examples())?;
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    let mut table = |title: &str,
                     column: &str,
                     angles: &[f32],
                     twist: bool,
                     pick: fn(kloub_core::candy::Quality) -> f32|
     -> Result<(), Box<dyn std::error::Error>> {
        println!("{title}\n");
        print!("| {column} |");
        for m in SkinningMethod::ALL {
            print!(" {} |", m.name());
        }
        println!("\n|---|{}", "---:|".repeat(SkinningMethod::ALL.len()));
        for &angle in angles {
            print!("| {angle:.0}° |");
            for method in SkinningMethod::ALL {
                instance.set_skinning(&rig.asset, method);
                let (t, b) = if twist { (angle, 0.0) } else { (0.0, angle) };
                rig.pose(&mut instance, t, b)?;
                instance.deform_primitive(&rig.asset, 2, 0, &mut positions, &mut normals)?;
                print!(" {:.3} |", pick(rig.quality(&positions)));
            }
            println!();
        }
        println!();
        Ok(())
    };
    table("Volume ratio to rest under bend", "bend", &[0.0, 30.0, 60.0, 90.0, 120.0, 150.0], false, |q| {
        q.volume_ratio
    })?;
    table("Radius kept at the joint under twist", "twist", &[0.0, 45.0, 90.0, 135.0, 150.0, 180.0], true, |q| {
        q.radius_kept
    })?;
    Ok(())
}
