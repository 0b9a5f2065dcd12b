//! Obstacles of the ragdoll's world (seed 000: the ragdoll collides "with the ground and
//! objects"): boxes, spheres, capsules and two presets, a staircase and a ramp, in model
//! units, and the JSON shape `kloub ragdoll --obstacles`, the sidecar's `obstacles` and the
//! element's `setObstacles` read:
//!
//! ```json
//! [ {"shape": "box", "center": [0, 0.25, 1], "size": [1, 0.5, 1], "rotation": [0, 0, 0, 1]},
//!   {"shape": "sphere", "center": [0.5, 0.2, 0], "radius": 0.2},
//!   {"shape": "capsule", "center": [0, 0.1, -1], "radius": 0.1, "height": 1, "rotation": [0, 0, 0.7071068, 0.7071068]},
//!   {"shape": "stairs", "center": [0, 0, 2], "size": [1.5, 0.9, 1.8], "steps": 6},
//!   {"shape": "ramp", "center": [0, 0, -2], "size": [1.5, 0.5, 2]} ]
//! ```
//!
//! - `center` is the shape's centre, except for `stairs` and `ramp`, whose `center` is the
//!   middle of their footprint on the floor (they rise from there); `rotation` (optional, a
//!   unit quaternion `[x, y, z, w]`) turns the shape about its centre (a staircase or ramp:
//!   about the vertical through its footprint's middle, whatever the quaternion's other axes).
//! - `size` is a box's full extent on X, Y, Z; a staircase's width (X), total rise (Y) and run
//!   (Z), climbing towards +Z; a ramp's likewise, a wedge rising towards +Z.
//! - `height` is a capsule's length between its caps' centres, along its local Y.
//! - At most [`MAX_OBSTACLES`] obstacles and [`MAX_STEPS`] steps per staircase; every number
//!   finite, sizes and radii positive. Errors name the JSON pointer (`/2/radius: …`).

use serde_json::{Value, json};

use crate::math::{Quat, QuatExt, Vec3};

/// Most obstacles in one world.
pub const MAX_OBSTACLES: usize = 64;

/// Most steps in one staircase.
pub const MAX_STEPS: u32 = 64;

/// Largest coordinate or size accepted (model units).
const MAX_EXTENT: f32 = 1e6;

/// One obstacle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Obstacle {
    /// A box: its centre, full size on each axis, rotation.
    Box {
        /// Centre.
        center: Vec3,
        /// Full extent on X, Y, Z.
        size: Vec3,
        /// Rotation about the centre.
        rotation: Quat,
    },
    /// A sphere.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
    /// A capsule along its local Y.
    Capsule {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Length between the caps' centres.
        height: f32,
        /// Rotation about the centre.
        rotation: Quat,
    },
    /// A staircase rising towards its local +Z from its footprint's middle on the floor.
    Stairs {
        /// Middle of the footprint.
        center: Vec3,
        /// Width, total rise, run.
        size: Vec3,
        /// Number of steps.
        steps: u32,
        /// Turn about the vertical.
        rotation: Quat,
    },
    /// A wedge rising towards its local +Z from its footprint's middle on the floor.
    Ramp {
        /// Middle of the footprint.
        center: Vec3,
        /// Width, rise, run.
        size: Vec3,
        /// Turn about the vertical.
        rotation: Quat,
    },
}

/// One convex piece of an obstacle, as the physics world and the viewer's overlay take it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Piece {
    /// A box: centre, half extents, rotation.
    Cuboid(Vec3, Vec3, Quat),
    /// A sphere: centre, radius.
    Ball(Vec3, f32),
    /// A capsule along its local Y: centre, half the length between the caps, radius, rotation.
    Capsule(Vec3, f32, f32, Quat),
    /// A convex hull of these points (a ramp's wedge: six corners).
    Hull([Vec3; 6]),
}

impl Obstacle {
    /// The shape's name in the JSON.
    pub fn name(&self) -> &'static str {
        match self {
            Obstacle::Box { .. } => "box",
            Obstacle::Sphere { .. } => "sphere",
            Obstacle::Capsule { .. } => "capsule",
            Obstacle::Stairs { .. } => "stairs",
            Obstacle::Ramp { .. } => "ramp",
        }
    }

    /// Its centre (the footprint's middle for stairs and ramps).
    pub fn center(&self) -> Vec3 {
        match *self {
            Obstacle::Box { center, .. }
            | Obstacle::Sphere { center, .. }
            | Obstacle::Capsule { center, .. }
            | Obstacle::Stairs { center, .. }
            | Obstacle::Ramp { center, .. } => center,
        }
    }

    /// The same obstacle moved so that its centre is `center`.
    pub fn moved_to(mut self, to: Vec3) -> Self {
        match &mut self {
            Obstacle::Box { center, .. }
            | Obstacle::Sphere { center, .. }
            | Obstacle::Capsule { center, .. }
            | Obstacle::Stairs { center, .. }
            | Obstacle::Ramp { center, .. } => *center = to,
        }
        self
    }

    /// Its convex pieces (a staircase is one box per step).
    pub fn pieces(&self) -> Vec<Piece> {
        match *self {
            Obstacle::Box { center, size, rotation } => vec![Piece::Cuboid(center, size * 0.5, rotation)],
            Obstacle::Sphere { center, radius } => vec![Piece::Ball(center, radius)],
            Obstacle::Capsule { center, radius, height, rotation } => {
                vec![Piece::Capsule(center, height * 0.5, radius, rotation)]
            }
            Obstacle::Stairs { center, size, steps, rotation } => {
                let turn = yaw(rotation);
                let n = steps.clamp(1, MAX_STEPS);
                let (rise, run) = (size.y / n as f32, size.z / n as f32);
                (0..n)
                    .map(|i| {
                        // Step i: from the floor up to its tread, i·run into the staircase.
                        let height = rise * (i + 1) as f32;
                        let local = Vec3::new(0.0, height * 0.5, -size.z * 0.5 + run * (i as f32 + 0.5));
                        Piece::Cuboid(center + turn * local, Vec3::new(size.x * 0.5, height * 0.5, run * 0.5), turn)
                    })
                    .collect()
            }
            Obstacle::Ramp { center, size, rotation } => {
                let turn = yaw(rotation);
                let (hx, hz) = (size.x * 0.5, size.z * 0.5);
                let corners = [
                    Vec3::new(-hx, 0.0, -hz),
                    Vec3::new(hx, 0.0, -hz),
                    Vec3::new(-hx, 0.0, hz),
                    Vec3::new(hx, 0.0, hz),
                    Vec3::new(-hx, size.y, hz),
                    Vec3::new(hx, size.y, hz),
                ];
                vec![Piece::Hull(corners.map(|c| center + turn * c))]
            }
        }
    }

    /// Reads a list of obstacles (see the module docs).
    ///
    /// # Errors
    /// `"<pointer>: <message>"`: not JSON, not an array, too many, an unknown shape, a missing
    /// or bad number, a rotation that is not a unit quaternion.
    pub fn list_from_json(json: &str) -> Result<Vec<Obstacle>, String> {
        let value: Value = serde_json::from_str(json).map_err(|e| format!("not JSON: {e}"))?;
        Self::list_from_value(&value, "")
    }

    /// [`Obstacle::list_from_json`] on a parsed value at `pointer` (`""` for a whole document,
    /// `"/obstacles"` in a sidecar).
    ///
    /// # Errors
    /// As [`Obstacle::list_from_json`].
    pub fn list_from_value(value: &Value, pointer: &str) -> Result<Vec<Obstacle>, String> {
        let items = value.as_array().ok_or_else(|| format!("{}: expected an array of obstacles", or_root(pointer)))?;
        if items.len() > MAX_OBSTACLES {
            return Err(format!("{pointer}/{MAX_OBSTACLES}: {} obstacles; at most {MAX_OBSTACLES}", items.len()));
        }
        items.iter().enumerate().map(|(i, item)| Self::from_value(item, &format!("{pointer}/{i}"))).collect()
    }

    fn from_value(item: &Value, ptr: &str) -> Result<Obstacle, String> {
        let obj = item.as_object().ok_or_else(|| format!("{ptr}: expected an object with a \"shape\""))?;
        let shape = obj
            .get("shape")
            .and_then(Value::as_str)
            .ok_or_else(|| format!("{ptr}/shape: expected \"box\", \"sphere\", \"capsule\", \"stairs\" or \"ramp\""))?;
        let center = vec3(obj.get("center"), &format!("{ptr}/center"), false)?;
        let rotation = match obj.get("rotation") {
            None | Some(Value::Null) => Quat::IDENTITY,
            Some(v) => {
                let p = format!("{ptr}/rotation");
                let xs = numbers(v, 4, &p)?;
                let q = Quat::from_xyzw(xs[0], xs[1], xs[2], xs[3]);
                q.check_unit().map_err(|l| format!("{p}: not a unit quaternion (length {l})"))?;
                q.normalize()
            }
        };
        let positive = |key: &str| -> Result<f32, String> {
            let p = format!("{ptr}/{key}");
            obj.get(key)
                .and_then(Value::as_f64)
                .map(|x| x as f32)
                .filter(|x| x.is_finite() && *x > 0.0 && *x <= MAX_EXTENT)
                .ok_or_else(|| format!("{p}: expected a positive number up to {MAX_EXTENT}"))
        };
        Ok(match shape {
            "box" => Obstacle::Box { center, size: vec3(obj.get("size"), &format!("{ptr}/size"), true)?, rotation },
            "sphere" => Obstacle::Sphere { center, radius: positive("radius")? },
            "capsule" => {
                Obstacle::Capsule { center, radius: positive("radius")?, height: positive("height")?, rotation }
            }
            "stairs" => {
                let steps = obj
                    .get("steps")
                    .and_then(Value::as_u64)
                    .filter(|s| (1..=u64::from(MAX_STEPS)).contains(s))
                    .ok_or_else(|| format!("{ptr}/steps: expected a whole number from 1 to {MAX_STEPS}"))?
                    as u32;
                Obstacle::Stairs { center, size: vec3(obj.get("size"), &format!("{ptr}/size"), true)?, steps, rotation }
            }
            "ramp" => Obstacle::Ramp { center, size: vec3(obj.get("size"), &format!("{ptr}/size"), true)?, rotation },
            other => {
                return Err(format!(
                    "{ptr}/shape: {other:?}: expected \"box\", \"sphere\", \"capsule\", \"stairs\" or \"ramp\""
                ));
            }
        })
    }

    /// The JSON object [`Obstacle::list_from_json`] reads back to this obstacle.
    pub fn to_value(&self) -> Value {
        let v = |x: Vec3| json!([x.x, x.y, x.z]);
        let q = |r: Quat| json!([r.x, r.y, r.z, r.w]);
        match *self {
            Obstacle::Box { center, size, rotation } => {
                json!({"shape": "box", "center": v(center), "size": v(size), "rotation": q(rotation)})
            }
            Obstacle::Sphere { center, radius } => json!({"shape": "sphere", "center": v(center), "radius": radius}),
            Obstacle::Capsule { center, radius, height, rotation } => json!({
                "shape": "capsule", "center": v(center), "radius": radius, "height": height, "rotation": q(rotation)
            }),
            Obstacle::Stairs { center, size, steps, rotation } => json!({
                "shape": "stairs", "center": v(center), "size": v(size), "steps": steps, "rotation": q(rotation)
            }),
            Obstacle::Ramp { center, size, rotation } => {
                json!({"shape": "ramp", "center": v(center), "size": v(size), "rotation": q(rotation)})
            }
        }
    }

    /// A list as JSON text.
    pub fn list_to_json(list: &[Obstacle]) -> String {
        Value::Array(list.iter().map(Obstacle::to_value).collect()).to_string()
    }

    /// The preset the viewer's "Add obstacle" places for a character of size `size` standing
    /// at `feet` (its ground point): beside it (+X) or, for a capsule, a staircase and a ramp,
    /// in front of it (+Z), clear of a standing character's footprint.
    pub fn preset(shape: &str, feet: Vec3, size: f32) -> Option<Obstacle> {
        let s = size.max(1e-3);
        Some(match shape {
            "box" => Obstacle::Box {
                center: feet + Vec3::new(0.5 * s, 0.15 * s, 0.0),
                size: Vec3::new(0.6 * s, 0.3 * s, 0.6 * s),
                rotation: Quat::IDENTITY,
            },
            "sphere" => Obstacle::Sphere { center: feet + Vec3::new(0.45 * s, 0.2 * s, 0.0), radius: 0.2 * s },
            "capsule" => Obstacle::Capsule {
                center: feet + Vec3::new(0.0, 0.08 * s, 0.4 * s),
                radius: 0.08 * s,
                height: 0.8 * s,
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            },
            "stairs" => Obstacle::Stairs {
                center: feet + Vec3::new(0.0, 0.0, 0.8 * s),
                size: Vec3::new(0.8 * s, 0.5 * s, 1.0 * s),
                steps: 5,
                rotation: Quat::from_rotation_y(std::f32::consts::PI),
            },
            "ramp" => Obstacle::Ramp {
                center: feet + Vec3::new(0.0, 0.0, 0.75 * s),
                size: Vec3::new(0.8 * s, 0.35 * s, 1.0 * s),
                rotation: Quat::from_rotation_y(std::f32::consts::PI),
            },
            _ => return None,
        })
    }
}

/// The turn about the vertical (Y) in `rotation`.
fn yaw(rotation: Quat) -> Quat {
    let forward = rotation * Vec3::Z;
    let flat = Vec3::new(forward.x, 0.0, forward.z);
    match flat.try_normalize() {
        Some(f) => Quat::from_rotation_y(f.x.atan2(f.z)),
        None => Quat::IDENTITY,
    }
}

fn or_root(pointer: &str) -> &str {
    if pointer.is_empty() { "/" } else { pointer }
}

fn numbers(v: &Value, n: usize, ptr: &str) -> Result<Vec<f32>, String> {
    let xs: Vec<f32> = v
        .as_array()
        .filter(|a| a.len() == n)
        .map(|a| a.iter().filter_map(Value::as_f64).map(|x| x as f32).collect())
        .filter(|xs: &Vec<f32>| xs.len() == n && xs.iter().all(|x| x.is_finite() && x.abs() <= MAX_EXTENT))
        .ok_or_else(|| format!("{ptr}: expected {n} finite numbers"))?;
    Ok(xs)
}

fn vec3(v: Option<&Value>, ptr: &str, positive: bool) -> Result<Vec3, String> {
    let v = v.ok_or_else(|| format!("{ptr}: missing"))?;
    let xs = numbers(v, 3, ptr)?;
    if positive && xs.iter().any(|x| *x <= 0.0) {
        return Err(format!("{ptr}: expected 3 positive numbers"));
    }
    Ok(Vec3::new(xs[0], xs[1], xs[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIST: &str = r#"[
      {"shape": "box", "center": [0, 0.25, 1], "size": [1, 0.5, 1], "rotation": [0, 0, 0, 1]},
      {"shape": "sphere", "center": [0.5, 0.2, 0], "radius": 0.2},
      {"shape": "capsule", "center": [0, 0.1, -1], "radius": 0.1, "height": 1, "rotation": [0, 0, 0.7071068, 0.7071068]},
      {"shape": "stairs", "center": [0, 0, 2], "size": [1.5, 0.9, 1.8], "steps": 6},
      {"shape": "ramp", "center": [0, 0, -2], "size": [1.5, 0.5, 2]}
    ]"#;

    #[test]
    fn the_documented_list_reads_and_round_trips() {
        let list = Obstacle::list_from_json(LIST).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(list.iter().map(Obstacle::name).collect::<Vec<_>>(), ["box", "sphere", "capsule", "stairs", "ramp"]);
        let again = Obstacle::list_from_json(&Obstacle::list_to_json(&list)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(again, list);
        // Six steps: six boxes, the last as high as the staircase, all on the floor.
        let steps = list[3].pieces();
        assert_eq!(steps.len(), 6);
        let Piece::Cuboid(c, h, _) = steps[5] else { panic!("a box") };
        assert!((c.y + h.y - 0.9).abs() < 1e-6 && (c.y - h.y).abs() < 1e-6, "{c} {h}");
        assert!((c.z - (2.0 + 0.9 - 0.15)).abs() < 1e-5, "the top step at the far end: {c}");
        let Piece::Hull(corners) = list[4].pieces()[0] else { panic!("a hull") };
        assert!((corners.iter().map(|c| c.y).fold(0.0, f32::max) - 0.5).abs() < 1e-6);
        assert_eq!(list[1].moved_to(Vec3::ONE).center(), Vec3::ONE);
        for name in ["box", "sphere", "capsule", "stairs", "ramp"] {
            let p = Obstacle::preset(name, Vec3::ZERO, 1.8).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(p.name(), name);
        }
        assert!(Obstacle::preset("cone", Vec3::ZERO, 1.0).is_none());
    }

    #[test]
    fn bad_lists_name_their_pointer() {
        let cases = [
            ("{}", "/: expected an array"),
            ("[1]", "/0: expected an object"),
            (r#"[{"shape": "cone", "center": [0, 0, 0]}]"#, "/0/shape: \"cone\""),
            (r#"[{"shape": "box", "center": [0, 0], "size": [1, 1, 1]}]"#, "/0/center: expected 3"),
            (r#"[{"shape": "box", "center": [0, 0, 0], "size": [1, -1, 1]}]"#, "/0/size: expected 3 positive"),
            (r#"[{"shape": "sphere", "center": [0, 0, 0], "radius": 0}]"#, "/0/radius"),
            (r#"[{"shape": "capsule", "center": [0, 0, 0], "radius": 1}]"#, "/0/height"),
            (r#"[{"shape": "stairs", "center": [0, 0, 0], "size": [1, 1, 1], "steps": 0}]"#, "/0/steps"),
            (
                r#"[{"shape": "box", "center": [0, 0, 0], "size": [1, 1, 1], "rotation": [0, 0, 2, 0]}]"#,
                "/0/rotation: not a unit",
            ),
            (r#"[{"shape": "sphere", "center": [0, 1e300, 0], "radius": 1}]"#, "/0/center"),
            ("not json", "not JSON"),
        ];
        for (json, want) in cases {
            let e = Obstacle::list_from_json(json).err().unwrap_or_default();
            assert!(e.contains(want), "{json}: {e}");
        }
        let many = format!(
            "[{}]",
            vec![r#"{"shape": "sphere", "center": [0, 0, 0], "radius": 1}"#; MAX_OBSTACLES + 1].join(",")
        );
        assert!(Obstacle::list_from_json(&many).is_err_and(|e| e.starts_with(&format!("/{MAX_OBSTACLES}"))));
    }
}
