//! The CesiumMan sample's example poses (`web/assets/CesiumMan/CesiumMan.kloub.json`, listed in
//! the viewer's Samples menu) are made by a scripted sculpt with the viewer's own sculpt code
//! ([`kloub_core::sculpt`], which the viewer's brushes call): the left elbow bent 70° and
//! 120° further than at rest, a biceps inflated on the inside of the bend with strokes along
//! the upper arm, then smoothed, as a user would in pose mode. This test sculpts again and
//! compares with the committed file (`KLOUB_BLESS=1` writes it).

use glam::{Quat, Vec3};
use kloub_core::asset::Asset;
use kloub_core::examples::{Examples, JointExample};
use kloub_core::instance::Instance;
use kloub_core::sculpt::{Brush, Dab, Sculpt, example_pose_locals};
use kloub_core::{ImportOptions, MapResolver};

/// The sample's sidecar, in the repository.
const SIDECAR: &str = "web/assets/CesiumMan/CesiumMan.kloub.json";

/// The elbow.
const ELBOW: &str = "Skeleton_arm_joint_L__3_";

/// The elbow's rotation bent 70° further than at rest (as the golden case `cesiumman_sjbbe_elbow`).
const BENT_70: [f32; 4] = [-0.0408211, -0.0582986, -0.572122, -0.8170749];

fn cesium_man() -> Asset {
    let path = kloub_tests::repo_root().join("web/assets/CesiumMan/CesiumMan.glb");
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    kloub_core::import(&bytes, &MapResolver::new(), &ImportOptions::default()).expect("CesiumMan imports").asset
}

fn node(asset: &Asset, name: &str) -> u32 {
    asset.nodes.iter().position(|n| n.name.as_deref() == Some(name)).unwrap_or_else(|| panic!("no {name}")) as u32
}

/// One example: the elbow at `rotation`, a biceps of `passes` inflate strokes, smoothed.
fn sculpt_example(asset: &Asset, rotation: Quat, passes: usize) -> JointExample {
    let elbow = node(asset, ELBOW);
    let mesh_node =
        asset.nodes.iter().position(|n| n.mesh.is_some() && n.skin.is_some()).expect("a skinned mesh") as u32;
    let mut instance = Instance::new(asset);
    // As the viewer does: the bind pose with the elbow turned, placed where the model stands.
    let placement = instance.worlds()[mesh_node as usize];
    for (n, t) in example_pose_locals(asset, instance.pose(), 0, elbow, rotation, placement).expect("the example pose")
    {
        instance.pose_mut().locals[n as usize] = t;
    }
    instance.update(asset).expect("updating");
    let mut sculpt = Sculpt::start(asset, &mut instance, mesh_node, elbow, rotation, placement).expect("the sculpt");
    // The upper arm from the shoulder to the elbow, and the inside of the bend (towards the forearm).
    let at = |n: u32| instance.worlds()[n as usize].w_axis.truncate();
    let shoulder = at(asset.nodes[elbow as usize].parent.expect("the elbow has a parent"));
    let (elbow_at, wrist) = (at(elbow), at(node(asset, "Skeleton_arm_joint_L__2_")));
    let axis = (elbow_at - shoulder).normalize();
    let forearm = wrist - elbow_at;
    let inside = (forearm - axis * forearm.dot(axis)).normalize();
    let length = (elbow_at - shoulder).length();
    let size = {
        let (lo, hi) = instance.scene_bounds(asset).expect("drawable");
        (hi - lo).length()
    };
    let stroke = |sculpt: &mut Sculpt, brush: Brush, radius: f32, strength: f32| {
        for i in 0..=8 {
            let along = shoulder + axis * length * (0.3 + 0.5 * i as f32 / 8.0);
            // A ray from outside the arm on the inside of the bend, as a pointer over it.
            let from = along + inside * size;
            if let Some(hit) = sculpt.pick(from, -inside) {
                sculpt.dab(&Dab { brush, center: hit, radius: radius * size, strength, drag: Vec3::ZERO });
            }
        }
    };
    for _ in 0..passes {
        stroke(&mut sculpt, Brush::Inflate, 0.05, 0.6);
    }
    stroke(&mut sculpt, Brush::Smooth, 0.07, 0.5);
    let shape = sculpt.finish(asset).expect("projected back to the reference pose");
    JointExample { node: elbow, mesh: sculpt.mesh, rotation, shape, pointer: String::new() }
}

/// The sample's examples, sculpted.
fn sculpted(asset: &Asset) -> Examples {
    let elbow = node(asset, ELBOW);
    let rest = asset.nodes[elbow as usize].rest.rotation;
    let bent = Quat::from_slice(&BENT_70).normalize();
    // The bend as a turn in the parent's frame, 70° of it; 120° is the same axis further.
    let (axis, angle) = (bent * rest.inverse()).to_axis_angle();
    let further = (Quat::from_axis_angle(axis, angle * 120.0 / 70.0) * rest).normalize();
    Examples { poses: vec![sculpt_example(asset, bent, 2), sculpt_example(asset, further, 3)], sigma: Vec::new() }
}

#[test]
fn the_cesium_man_samples_example_poses_are_the_scripted_sculpt() {
    let asset = cesium_man();
    let made = sculpted(&asset);
    let text = serde_json::to_string_pretty(&serde_json::Value::Object(made.to_json(&asset))).expect("JSON") + "\n";
    let path = kloub_tests::repo_root().join(SIDECAR);
    if std::env::var_os("KLOUB_BLESS").is_some() {
        std::fs::write(&path, &text).expect("writing the sidecar");
    }
    let committed =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e} (KLOUB_BLESS=1 makes it)", path.display()));
    let read = Examples::from_json(&asset, &committed).expect("the committed sidecar reads");
    assert_eq!(read.poses.len(), made.poses.len());
    let diagonal = {
        let (lo, hi) = asset.meshes[0].primitives[0].bounds;
        (Vec3::from(hi) - Vec3::from(lo)).length()
    };
    for (a, b) in read.poses.iter().zip(&made.poses) {
        assert_eq!((a.node, a.mesh), (b.node, b.mesh));
        assert!(a.rotation.dot(b.rotation).abs() > 1.0 - 1e-6);
        let (
            kloub_core::examples::ExampleShape::Inline { positions: pa, .. },
            kloub_core::examples::ExampleShape::Inline { positions: pb, .. },
        ) = (&a.shape, &b.shape)
        else {
            panic!("inline shapes")
        };
        let worst = pa.iter().zip(pb).map(|(x, y)| Vec3::from(*x).distance(Vec3::from(*y))).fold(0.0, f32::max);
        assert!(worst <= 1e-5 * diagonal, "the committed sample differs from the sculpt by {worst}");
        // A biceps: some vertices moved a visible amount, none absurdly far.
        let largest = pb.iter().map(|x| Vec3::from(*x).length()).fold(0.0, f32::max);
        assert!(largest > 0.005 * diagonal && largest < 0.1 * diagonal, "largest offset {largest} of {diagonal}");
    }
    // The examples load as the viewer loads them: SJB by example shapes the arm, α = 1 at each.
    let mut rigs = Instance::new(&asset);
    rigs.set_examples(&asset, &read).expect("the rig builds");
}
